/* screenshot.c — glReadPixels to PNG. */
#include "screenshot.h"

#include <epoxy/gl.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "out_file.h"

int vv_screenshot(const char *path, int w, int h, char *err, size_t err_size)
{
    if (w <= 0 || h <= 0) {
        snprintf(err, err_size, "%s: empty framebuffer", path);
        return -1;
    }
    size_t row = (size_t)w * 3;
    unsigned char *px = malloc(row * (size_t)h), *flip = malloc(row * (size_t)h);
    if (!px || !flip) {
        free(px), free(flip);
        snprintf(err, err_size, "%s: out of memory for a %dx%d picture", path, w, h);
        return -1;
    }
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadBuffer(GL_BACK);
    glReadPixels(0, 0, w, h, GL_RGB, GL_UNSIGNED_BYTE, px);
    for (int y = 0; y < h; ++y) /* GL's rows go up; PNG's go down */
        memcpy(flip + row * (size_t)y, px + row * (size_t)(h - 1 - y), row);
    free(px);
    png_image image;
    memset(&image, 0, sizeof image);
    image.version = PNG_IMAGE_VERSION;
    image.width = (png_uint_32)w;
    image.height = (png_uint_32)h;
    image.format = PNG_FORMAT_RGB;
    vc_out_file o;
    int rc = -1;
    if (vc_out_open(&o, path, err, err_size) == 0) {
        int ok = png_image_write_to_stdio(&image, o.f, 0, flip, (png_int_32)row, NULL) != 0;
        if (!ok)
            snprintf(err, err_size, "%s: libpng: %s", path, image.message);
        rc = vc_out_close(&o, ok, err, err_size) == 0 && ok ? 0 : -1;
    }
    png_image_free(&image);
    free(flip);
    return rc;
}
