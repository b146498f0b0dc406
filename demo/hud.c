/* hud.c — bitmap-font text: glyphs in an R8 texture (96 cells of 6x8), quads built on the
 * CPU each frame into a buffer allocated once. */
#include "hud.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "font5x7.h"
#include "gl_util.h"

#define CELL_W 6
#define CELL_H 8
#define FIRST 32
#define GLYPHS 96
#define MAX_QUADS 8192

typedef struct hud_vertex {
    float x, y, u, v;
    float r, g, b, a;
} hud_vertex;

struct vv_hud {
    GLuint prog, tex, vao, vbo;
    GLint u_screen, u_tex;
    hud_vertex *verts;
    int quads;
    int fb_w, fb_h, scale;
};

static const char *vs_src =
    "#version 330 core\n"
    "layout(location = 0) in vec4 pos_uv;\n"
    "layout(location = 1) in vec4 rgba;\n"
    "uniform vec2 screen;\n"
    "out vec2 uv; out vec4 colour;\n"
    "void main() {\n"
    "  uv = pos_uv.zw; colour = rgba;\n"
    "  gl_Position = vec4(pos_uv.x / screen.x * 2.0 - 1.0, 1.0 - pos_uv.y / screen.y * 2.0, 0.0, 1.0);\n"
    "}\n";

/* u < 0: a solid band; else the glyph's coverage. */
static const char *fs_src =
    "#version 330 core\n"
    "in vec2 uv; in vec4 colour;\n"
    "uniform sampler2D glyphs;\n"
    "out vec4 frag;\n"
    "void main() {\n"
    "  if (uv.x < 0.0) { frag = colour; return; }\n"
    "  float a = texture(glyphs, uv).r;\n"
    "  if (a < 0.5) discard;\n"
    "  frag = colour;\n"
    "}\n";

vv_hud *vv_hud_create(void)
{
    vv_hud *h = calloc(1, sizeof *h);
    if (!h)
        return NULL;
    h->verts = malloc((size_t)MAX_QUADS * 6 * sizeof *h->verts);
    h->prog = vv_gl_program("hud", vs_src, fs_src);
    if (!h->verts || !h->prog) {
        vv_hud_destroy(h);
        return NULL;
    }
    h->u_screen = glGetUniformLocation(h->prog, "screen");
    h->u_tex = glGetUniformLocation(h->prog, "glyphs");
    unsigned char *atlas = calloc((size_t)GLYPHS * CELL_W * CELL_H, 1);
    if (!atlas) {
        vv_hud_destroy(h);
        return NULL;
    }
    for (int g = 0; g < GLYPHS; ++g) {
        uint8_t rows[VV_FONT_H];
        if (!vv_font_glyph((char)(FIRST + g), rows))
            continue;
        for (int y = 0; y < VV_FONT_H; ++y)
            for (int x = 0; x < VV_FONT_W; ++x)
                if (rows[y] & (1u << (VV_FONT_W - 1 - x)))
                    atlas[(size_t)y * GLYPHS * CELL_W + (size_t)g * CELL_W + (size_t)x] = 255;
    }
    glGenTextures(1, &h->tex);
    glBindTexture(GL_TEXTURE_2D, h->tex);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_R8, GLYPHS * CELL_W, CELL_H, 0, GL_RED, GL_UNSIGNED_BYTE, atlas);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    free(atlas);
    glGenVertexArrays(1, &h->vao);
    glGenBuffers(1, &h->vbo);
    glBindVertexArray(h->vao);
    glBindBuffer(GL_ARRAY_BUFFER, h->vbo);
    glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)((size_t)MAX_QUADS * 6 * sizeof(hud_vertex)), NULL, GL_DYNAMIC_DRAW);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, sizeof(hud_vertex), (void *)0);
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, sizeof(hud_vertex), (void *)(4 * sizeof(float)));
    glBindVertexArray(0);
    return h;
}

void vv_hud_destroy(vv_hud *h)
{
    if (!h)
        return;
    if (h->vbo)
        glDeleteBuffers(1, &h->vbo);
    if (h->vao)
        glDeleteVertexArrays(1, &h->vao);
    if (h->tex)
        glDeleteTextures(1, &h->tex);
    if (h->prog)
        glDeleteProgram(h->prog);
    free(h->verts);
    free(h);
}

void vv_hud_begin(vv_hud *h, int fb_w, int fb_h, int scale)
{
    h->quads = 0;
    h->fb_w = fb_w;
    h->fb_h = fb_h;
    h->scale = scale < 1 ? 1 : scale;
}

static void quad(vv_hud *h, float x0, float y0, float x1, float y1, float u0, float v0, float u1, float v1,
                 const float c[4])
{
    if (h->quads >= MAX_QUADS)
        return;
    hud_vertex *o = &h->verts[(size_t)h->quads * 6];
    const float px[6] = {x0, x1, x1, x0, x1, x0}, py[6] = {y0, y0, y1, y0, y1, y1};
    const float pu[6] = {u0, u1, u1, u0, u1, u0}, pv[6] = {v0, v0, v1, v0, v1, v1};
    for (int i = 0; i < 6; ++i) {
        o[i].x = px[i], o[i].y = py[i], o[i].u = pu[i], o[i].v = pv[i];
        o[i].r = c[0], o[i].g = c[1], o[i].b = c[2], o[i].a = c[3];
    }
    h->quads++;
}

/* The text at (x, y) over its band; returns the x just past it. */
static int text(vv_hud *h, int x, int y, const float rgb[3], const char *fmt, va_list ap)
{
    char str[256];
    vsnprintf(str, sizeof str, fmt, ap);
    int s = h->scale, n = (int)strlen(str);
    const float band[4] = {0.0f, 0.0f, 0.0f, 0.6f}, col[4] = {rgb[0], rgb[1], rgb[2], 1.0f};
    quad(h, (float)(x - s), (float)(y - s), (float)(x + n * CELL_W * s + s), (float)(y + CELL_H * s), -1, -1, -1, -1,
         band);
    for (int i = 0; i < n; ++i) {
        int g = (unsigned char)str[i] - FIRST;
        if (g <= 0 || g >= GLYPHS)
            continue;
        float u0 = (float)(g * CELL_W) / (float)(GLYPHS * CELL_W), u1 = (float)(g * CELL_W + VV_FONT_W) / (float)(GLYPHS * CELL_W);
        float x0 = (float)(x + i * CELL_W * s), y0 = (float)y;
        quad(h, x0, y0, x0 + (float)(VV_FONT_W * s), y0 + (float)(VV_FONT_H * s), u0, 0.0f, u1,
             (float)VV_FONT_H / (float)CELL_H, col);
    }
    return x + n * CELL_W * s;
}

int vv_hud_line(vv_hud *h, int x, int y, const float rgb[3], const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    text(h, x, y, rgb, fmt, ap);
    va_end(ap);
    return y + (CELL_H + 2) * h->scale;
}

int vv_hud_span(vv_hud *h, int x, int y, const float rgb[3], const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int end = text(h, x, y, rgb, fmt, ap);
    va_end(ap);
    return end;
}

void vv_hud_end(vv_hud *h)
{
    if (!h->quads)
        return;
    glDisable(GL_DEPTH_TEST);
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glUseProgram(h->prog);
    glUniform2f(h->u_screen, (float)h->fb_w, (float)h->fb_h);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, h->tex);
    glUniform1i(h->u_tex, 0);
    glBindVertexArray(h->vao);
    glBindBuffer(GL_ARRAY_BUFFER, h->vbo);
    glBufferSubData(GL_ARRAY_BUFFER, 0, (GLsizeiptr)((size_t)h->quads * 6 * sizeof(hud_vertex)), h->verts);
    glDrawArrays(GL_TRIANGLES, 0, h->quads * 6);
    glBindVertexArray(0);
    glDisable(GL_BLEND);
    glEnable(GL_DEPTH_TEST);
}
