/* overlays.c — pictures of the culler's buffers and lines in the world. The picture
 * texture and the line buffer are allocated once (1024^2 texels, 256k line vertices). */
#include "overlays.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gl_util.h"

#define TEX 1024u
#define MAX_LINE_VERTS (256u * 1024u)

typedef struct line_vertex {
    float p[3];
    uint32_t rgba;
} line_vertex;

struct vv_overlays {
    GLuint img_prog, img_tex, img_vao, img_vbo;
    GLint u_img_screen, u_img_tex;
    uint32_t *pixels;              /* TEX * TEX                                          */
    GLuint line_prog, line_vao, line_vbo;
    GLint u_line_mvp;
    line_vertex *lines;
    uint32_t line_count;
};

static const char *img_vs =
    "#version 330 core\n"
    "layout(location = 0) in vec4 pos_uv;\n"
    "uniform vec2 screen;\n"
    "out vec2 uv;\n"
    "void main() { uv = pos_uv.zw;\n"
    "  gl_Position = vec4(pos_uv.x / screen.x * 2.0 - 1.0, 1.0 - pos_uv.y / screen.y * 2.0, 0.0, 1.0); }\n";
static const char *img_fs =
    "#version 330 core\n"
    "in vec2 uv; uniform sampler2D img; out vec4 frag;\n"
    "void main() { frag = vec4(texture(img, uv).rgb, 1.0); }\n";
static const char *line_vs =
    "#version 330 core\n"
    "layout(location = 0) in vec3 pos;\n"
    "layout(location = 1) in vec4 rgba;\n"
    "uniform mat4 mvp; flat out vec4 colour;\n"
    "void main() { colour = rgba; gl_Position = mvp * vec4(pos, 1.0); }\n";
static const char *line_fs =
    "#version 330 core\n"
    "flat in vec4 colour; out vec4 frag;\n"
    "void main() { frag = colour; }\n";

vv_overlays *vv_overlays_create(void)
{
    vv_overlays *o = calloc(1, sizeof *o);
    if (!o)
        return NULL;
    o->pixels = malloc((size_t)TEX * TEX * sizeof *o->pixels);
    o->lines = malloc((size_t)MAX_LINE_VERTS * sizeof *o->lines);
    o->img_prog = vv_gl_program("overlay", img_vs, img_fs);
    o->line_prog = vv_gl_program("lines", line_vs, line_fs);
    if (!o->pixels || !o->lines || !o->img_prog || !o->line_prog) {
        vv_overlays_destroy(o);
        return NULL;
    }
    o->u_img_screen = glGetUniformLocation(o->img_prog, "screen");
    o->u_img_tex = glGetUniformLocation(o->img_prog, "img");
    o->u_line_mvp = glGetUniformLocation(o->line_prog, "mvp");
    glGenTextures(1, &o->img_tex);
    glBindTexture(GL_TEXTURE_2D, o->img_tex);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, TEX, TEX, 0, GL_RGBA, GL_UNSIGNED_BYTE, NULL);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glGenVertexArrays(1, &o->img_vao);
    glGenBuffers(1, &o->img_vbo);
    glBindVertexArray(o->img_vao);
    glBindBuffer(GL_ARRAY_BUFFER, o->img_vbo);
    glBufferData(GL_ARRAY_BUFFER, 6 * 4 * sizeof(float), NULL, GL_DYNAMIC_DRAW);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, 4 * sizeof(float), (void *)0);
    glGenVertexArrays(1, &o->line_vao);
    glGenBuffers(1, &o->line_vbo);
    glBindVertexArray(o->line_vao);
    glBindBuffer(GL_ARRAY_BUFFER, o->line_vbo);
    glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)((size_t)MAX_LINE_VERTS * sizeof(line_vertex)), NULL, GL_DYNAMIC_DRAW);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(line_vertex), (void *)0);
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 4, GL_UNSIGNED_BYTE, GL_TRUE, sizeof(line_vertex), (void *)(3 * sizeof(float)));
    glBindVertexArray(0);
    return o;
}

void vv_overlays_destroy(vv_overlays *o)
{
    if (!o)
        return;
    if (o->img_tex)
        glDeleteTextures(1, &o->img_tex);
    if (o->img_vbo)
        glDeleteBuffers(1, &o->img_vbo);
    if (o->img_vao)
        glDeleteVertexArrays(1, &o->img_vao);
    if (o->line_vbo)
        glDeleteBuffers(1, &o->line_vbo);
    if (o->line_vao)
        glDeleteVertexArrays(1, &o->line_vao);
    if (o->img_prog)
        glDeleteProgram(o->img_prog);
    if (o->line_prog)
        glDeleteProgram(o->line_prog);
    free(o->pixels);
    free(o->lines);
    free(o);
}

uint32_t vv_id_colour(uint32_t id)
{
    if (id == 0)
        return 0xFF000000u;
    uint32_t h = id; /* the murmur3 finaliser */
    h ^= h >> 16;
    h *= 0x85ebca6bu;
    h ^= h >> 13;
    h *= 0xc2b2ae35u;
    h ^= h >> 16;
    uint32_t r = 48 + (h & 0xFFu) % 208, g = 48 + ((h >> 8) & 0xFFu) % 208, b = 48 + ((h >> 16) & 0xFFu) % 208;
    return 0xFF000000u | (b << 16) | (g << 8) | r;
}

static void draw_image(vv_overlays *o, uint32_t w, uint32_t h, int x, int y, int sw, int sh, int fb_w, int fb_h)
{
    glBindTexture(GL_TEXTURE_2D, o->img_tex);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, (GLsizei)w, (GLsizei)h, GL_RGBA, GL_UNSIGNED_BYTE, o->pixels);
    float u1 = (float)w / TEX, v1 = (float)h / TEX;
    float x0 = (float)x, y0 = (float)y, x1 = (float)(x + sw), y1 = (float)(y + sh);
    const float v[6][4] = {{x0, y0, 0, 0}, {x1, y0, u1, 0}, {x1, y1, u1, v1},
                           {x0, y0, 0, 0}, {x1, y1, u1, v1}, {x0, y1, 0, v1}};
    glDisable(GL_DEPTH_TEST);
    glUseProgram(o->img_prog);
    glUniform2f(o->u_img_screen, (float)fb_w, (float)fb_h);
    glActiveTexture(GL_TEXTURE0);
    glUniform1i(o->u_img_tex, 0);
    glBindVertexArray(o->img_vao);
    glBindBuffer(GL_ARRAY_BUFFER, o->img_vbo);
    glBufferSubData(GL_ARRAY_BUFFER, 0, sizeof v, v);
    glDrawArrays(GL_TRIANGLES, 0, 6);
    glBindVertexArray(0);
    glEnable(GL_DEPTH_TEST);
}

void vv_overlay_ids(vv_overlays *o, const uint32_t *ids, uint32_t w, uint32_t h, int x, int y, int sw, int sh,
                    int fb_w, int fb_h)
{
    if (w > TEX || h > TEX)
        return;
    for (size_t i = 0, n = (size_t)w * h; i < n; ++i)
        o->pixels[i] = vv_id_colour(ids[i]);
    draw_image(o, w, h, x, y, sw, sh, fb_w, fb_h);
}

void vv_overlay_depth(vv_overlays *o, const float *depth, uint32_t w, uint32_t h, float far_depth, int x, int y,
                      int sw, int sh, int fb_w, int fb_h)
{
    if (w > TEX || h > TEX)
        return;
    /* Grey from the nearest to the farthest depth in the buffer (at most far_depth), near
     * bright: the range of one view, so that its shapes read. */
    size_t n = (size_t)w * h;
    float lo = INFINITY, hi = 0.0f;
    for (size_t i = 0; i < n; ++i)
        if (isfinite(depth[i])) {
            lo = depth[i] < lo ? depth[i] : lo;
            hi = depth[i] > hi ? depth[i] : hi;
        }
    hi = hi > far_depth ? far_depth : hi;
    float span = hi > lo ? hi - lo : 1.0f;
    for (size_t i = 0; i < n; ++i) {
        float d = depth[i];
        uint32_t g = 0;
        if (isfinite(d)) {
            float t = 1.0f - (d - lo) / span;
            t = t < 0.0f ? 0.0f : t > 1.0f ? 1.0f : t;
            g = 40u + (uint32_t)(t * 215.0f);
        }
        o->pixels[i] = 0xFF000000u | (g << 16) | (g << 8) | g;
    }
    draw_image(o, w, h, x, y, sw, sh, fb_w, fb_h);
}

void vv_overlay_cost(vv_overlays *o, const uint32_t *cost, uint32_t w, uint32_t h, int x, int y, int sw, int sh,
                     int fb_w, int fb_h)
{
    if (w > TEX || h > TEX)
        return;
    size_t n = (size_t)w * h;
    uint32_t lo = UINT32_MAX, hi = 0;
    for (size_t i = 0; i < n; ++i) {
        lo = cost[i] < lo ? cost[i] : lo;
        hi = cost[i] > hi ? cost[i] : hi;
    }
    double l0 = log2(1.0 + lo), span = log2(1.0 + hi) - l0;
    for (size_t i = 0; i < n; ++i) {
        double t = span > 0.0 ? (log2(1.0 + cost[i]) - l0) / span : 0.0;
        /* blue -> cyan -> green -> yellow -> red */
        double r = t < 0.5 ? 0.0 : t < 0.75 ? (t - 0.5) * 4.0 : 1.0;
        double g = t < 0.25 ? t * 4.0 : t < 0.75 ? 1.0 : (1.0 - t) * 4.0;
        double b = t < 0.25 ? 1.0 : t < 0.5 ? (0.5 - t) * 4.0 : 0.0;
        uint32_t R = (uint32_t)(r * 255.0), G = (uint32_t)(g * 255.0), B = (uint32_t)(40.0 + b * 215.0);
        o->pixels[i] = 0xFF000000u | (B << 16) | (G << 8) | R;
    }
    draw_image(o, w, h, x, y, sw, sh, fb_w, fb_h);
}

void vv_lines_begin(vv_overlays *o) { o->line_count = 0; }

void vv_lines_add(vv_overlays *o, const float a[3], const float b[3], uint32_t rgba)
{
    if (o->line_count + 2 > MAX_LINE_VERTS)
        return;
    line_vertex *v = &o->lines[o->line_count];
    memcpy(v[0].p, a, 3 * sizeof *a);
    memcpy(v[1].p, b, 3 * sizeof *b);
    v[0].rgba = v[1].rgba = rgba;
    o->line_count += 2;
}

void vv_lines_box(vv_overlays *o, const float lo[3], const float hi[3], uint32_t rgba)
{
    float c[8][3];
    for (int i = 0; i < 8; ++i) {
        c[i][0] = i & 1 ? hi[0] : lo[0];
        c[i][1] = i & 2 ? hi[1] : lo[1];
        c[i][2] = i & 4 ? hi[2] : lo[2];
    }
    static const int e[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                                 {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
    for (int i = 0; i < 12; ++i)
        vv_lines_add(o, c[e[i][0]], c[e[i][1]], rgba);
}

void vv_lines_end(vv_overlays *o, const float mvp[16])
{
    if (!o->line_count)
        return;
    glUseProgram(o->line_prog);
    glUniformMatrix4fv(o->u_line_mvp, 1, GL_FALSE, mvp);
    glBindVertexArray(o->line_vao);
    glBindBuffer(GL_ARRAY_BUFFER, o->line_vbo);
    glBufferSubData(GL_ARRAY_BUFFER, 0, (GLsizeiptr)((size_t)o->line_count * sizeof(line_vertex)), o->lines);
    glDrawArrays(GL_LINES, 0, (GLsizei)o->line_count);
    glBindVertexArray(0);
}
