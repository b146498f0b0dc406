/* hud.h — on-screen text with the viewer's own 5x7 bitmap font (font5x7.c): one glyph
 * texture, one vertex buffer filled per frame, drawn in one call over a dark panel. */
#ifndef VIS_VIEWER_HUD_H
#define VIS_VIEWER_HUD_H

typedef struct vv_hud vv_hud;

vv_hud *vv_hud_create(void);
void vv_hud_destroy(vv_hud *h);

/* Starts a frame of text for a framebuffer of w x h pixels; scale: pixels per font pixel. */
void vv_hud_begin(vv_hud *h, int fb_w, int fb_h, int scale);
/* A line of text at (x, y) pixels from the top left; returns the y of the next line. Text
 * beyond the buffer's room is dropped. */
int vv_hud_line(vv_hud *h, int x, int y, const float rgb[3], const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 5, 6)))
#endif
    ;
/* Text at (x, y) that a line goes on after (several colours on one line); returns the x
 * just past it. */
int vv_hud_span(vv_hud *h, int x, int y, const float rgb[3], const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 5, 6)))
#endif
    ;
/* Draws what was added since vv_hud_begin, each line over a translucent dark band. */
void vv_hud_end(vv_hud *h);

#endif
