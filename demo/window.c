/* window.c — GLFW window, GL context and input. */
#include "window.h"

#include <epoxy/gl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* GLFW reports errors through a callback without a user pointer; the message is kept for
 * the one failure message the viewer prints (the viewer is single-threaded). */
static char glfw_message[512];

static void on_error(int code, const char *message)
{
    snprintf(glfw_message, sizeof glfw_message, "%s (GLFW error 0x%x)", message, code);
}

static void on_key(GLFWwindow *win, int key, int scancode, int action, int mods)
{
    (void)scancode, (void)mods;
    vv_window *w = glfwGetWindowUserPointer(win);
    if (action == GLFW_PRESS && key >= 0 && key < VV_KEYS)
        w->in.pressed[key] = 1;
}

static void on_scroll(GLFWwindow *win, double x, double y)
{
    (void)x;
    vv_window *w = glfwGetWindowUserPointer(win);
    w->in.wheel += y;
}

static void on_button(GLFWwindow *win, int button, int action, int mods)
{
    (void)mods;
    vv_window *w = glfwGetWindowUserPointer(win);
    double x, y;
    glfwGetCursorPos(win, &x, &y);
    if (button == GLFW_MOUSE_BUTTON_LEFT && action == GLFW_PRESS) {
        w->press_x = x, w->press_y = y;
    } else if (button == GLFW_MOUSE_BUTTON_LEFT && action == GLFW_RELEASE) {
        if ((x - w->press_x) * (x - w->press_x) + (y - w->press_y) * (y - w->press_y) < 9.0) {
            int ww, wh;
            glfwGetWindowSize(win, &ww, &wh);
            w->in.clicked = 1;
            w->in.click_x = ww > 0 ? x * w->fb_w / ww : x;
            w->in.click_y = wh > 0 ? y * w->fb_h / wh : y;
        }
    }
}

static void on_cursor(GLFWwindow *win, double x, double y)
{
    vv_window *w = glfwGetWindowUserPointer(win);
    if (w->have_last) {
        double dx = x - w->last_x, dy = y - w->last_y;
        if (glfwGetMouseButton(win, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS)
            w->in.dx += dx, w->in.dy += dy;
        if (glfwGetMouseButton(win, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS)
            w->in.odx += dx, w->in.ody += dy;
    }
    w->last_x = x, w->last_y = y, w->have_last = 1;
}

int vv_window_open(vv_window *w, int width, int height, int visible, const char *title)
{
    memset(w, 0, sizeof *w);
    glfwSetErrorCallback(on_error);
    const char *display = getenv("DISPLAY"), *wayland = getenv("WAYLAND_DISPLAY");
    if ((!display || !*display) && (!wayland || !*wayland)) {
        fprintf(stderr, "vis-viewer: no display: DISPLAY is not set (for a headless run use "
                        "`xvfb-run -a vis-viewer ...`)\n");
        return -1;
    }
    if (!glfwInit()) {
        fprintf(stderr, "vis-viewer: cannot open a window: %s\n", glfw_message[0] ? glfw_message : "glfwInit failed");
        return -1;
    }
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    glfwWindowHint(GLFW_RESIZABLE, GLFW_TRUE);
    glfwWindowHint(GLFW_VISIBLE, visible ? GLFW_TRUE : GLFW_FALSE);
    glfwWindowHint(GLFW_SAMPLES, 0);
    w->win = glfwCreateWindow(width, height, title, NULL, NULL);
    if (!w->win) {
        fprintf(stderr, "vis-viewer: cannot create an OpenGL 3.3 core window: %s\n",
                glfw_message[0] ? glfw_message : "unknown reason");
        glfwTerminate();
        return -1;
    }
    glfwMakeContextCurrent(w->win);
    if (epoxy_gl_version() < 33) {
        fprintf(stderr, "vis-viewer: OpenGL %d.%d is below 3.3\n", epoxy_gl_version() / 10, epoxy_gl_version() % 10);
        vv_window_close(w);
        return -1;
    }
    glfwSwapInterval(visible ? 1 : 0);
    glfwSetWindowUserPointer(w->win, w);
    glfwSetKeyCallback(w->win, on_key);
    glfwSetScrollCallback(w->win, on_scroll);
    glfwSetMouseButtonCallback(w->win, on_button);
    glfwSetCursorPosCallback(w->win, on_cursor);
    glfwGetFramebufferSize(w->win, &w->fb_w, &w->fb_h);
    return 0;
}

void vv_window_close(vv_window *w)
{
    if (w->win)
        glfwDestroyWindow(w->win);
    w->win = NULL;
    glfwTerminate();
}

int vv_window_poll(vv_window *w)
{
    memset(&w->in, 0, sizeof w->in);
    glfwPollEvents();
    glfwGetFramebufferSize(w->win, &w->fb_w, &w->fb_h);
    return !glfwWindowShouldClose(w->win);
}

int vv_window_key_down(const vv_window *w, int key) { return glfwGetKey(w->win, key) == GLFW_PRESS; }
