/* screenshot.h — the framebuffer as a PNG (libpng), written through out_file.h so that a
 * failed write never destroys the file that was there. */
#ifndef VIS_VIEWER_SCREENSHOT_H
#define VIS_VIEWER_SCREENSHOT_H

#include <stddef.h>

/* Reads the back buffer (w x h) and writes it as RGB PNG. 0, or -1 with err. */
int vv_screenshot(const char *path, int w, int h, char *err, size_t err_size);

#endif
