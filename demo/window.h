/* window.h — the GLFW window (OpenGL 3.3 core through libepoxy) and its input, gathered per
 * frame: keys pressed since the last frame, keys held, mouse motion, wheel and clicks. */
#ifndef VIS_VIEWER_WINDOW_H
#define VIS_VIEWER_WINDOW_H

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#define VV_KEYS (GLFW_KEY_LAST + 1)

typedef struct vv_input {
    unsigned char pressed[VV_KEYS]; /* went down since the last vv_window_poll           */
    double dx, dy;                  /* cursor motion (pixels) with the right button held  */
    double odx, ody;                /* cursor motion with the left button held (orbit)    */
    double wheel;
    int clicked;                    /* left button released without dragging             */
    double click_x, click_y;        /* where, in framebuffer pixels                       */
} vv_input;

typedef struct vv_window {
    GLFWwindow *win;
    int fb_w, fb_h;
    vv_input in;
    double last_x, last_y;
    double press_x, press_y;
    int have_last;
} vv_window;

/* Opens the window (visible: 0 for the scripted mode). Prints a clear message and returns
 * -1 when there is no display, GLFW fails, or the context is below OpenGL 3.3 core. */
int vv_window_open(vv_window *w, int width, int height, int visible, const char *title);
void vv_window_close(vv_window *w);

/* Polls events into w->in (cleared first). Returns 0 when the window should close. */
int vv_window_poll(vv_window *w);
int vv_window_key_down(const vv_window *w, int key);

#endif
