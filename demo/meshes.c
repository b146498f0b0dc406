/* meshes.c — chunk meshes as vertex buffers, drawn by draw list. */
#include "meshes.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gl_util.h"

typedef struct vv_vertex {
    float p[3];
    uint8_t rgba[4];
    uint8_t face[4]; /* face[0]: 0 top, 1 bottom, 2 x, 3 z; face[1]: 1 see-through   */
} vv_vertex;

typedef struct vv_object {
    GLuint vao, vbo;
    uint32_t quads;
    float lo[3], hi[3];
} vv_object;

struct vv_meshes {
    vw_world *world;
    uint32_t slots;       /* object IDs 1..slots (one per chunk)                       */
    vv_object *obj;       /* [id - 1]                                                  */
    GLuint ibo;           /* 0,1,2, 0,2,3 per quad, shared by every object             */
    uint32_t ibo_quads;
    vv_vertex *staging;   /* grown to the largest mesh                                 */
    size_t staging_cap;
    GLuint prog;
    GLint u_mvp, u_shade, u_tint, u_door;
    uint64_t total_quads;
    uint32_t objects;
    int failed;
};

static const char *vs_src =
    "#version 330 core\n"
    "layout(location = 0) in vec3 pos;\n"
    "layout(location = 1) in vec4 rgba;\n"
    "layout(location = 2) in vec4 face;\n"
    "uniform mat4 mvp;\n"
    "uniform vec4 shade;\n"
    "uniform vec4 tint;\n" /* a > 0: the object's tint replaces the material colour */
    "flat out vec3 colour;\n"
    "flat out int see_through;\n"
    "void main() {\n"
    "  int f = int(face.x + 0.5);\n"
    "  float s = f == 0 ? shade.x : f == 1 ? shade.y : f == 2 ? shade.z : shade.w;\n"
    "  colour = (tint.a > 0.0 ? tint.rgb : rgba.rgb) * s;\n"
    "  see_through = int(face.y + 0.5);\n"
    "  gl_Position = mvp * vec4(pos, 1.0);\n"
    "}\n";

/* The screen door: a see-through quad leaves out every other pixel (Fuchs et al. 1985's
 * "screen-door transparency"), which needs neither blending nor a back-to-front order. */
static const char *fs_src =
    "#version 330 core\n"
    "flat in vec3 colour;\n"
    "flat in int see_through;\n"
    "uniform int door;\n"
    "out vec4 frag;\n"
    "void main() {\n"
    "  if (door != 0 && see_through != 0 && ((int(gl_FragCoord.x) + int(gl_FragCoord.y)) & 1) != 0) discard;\n"
    "  frag = vec4(colour, 1.0);\n"
    "}\n";

int vv_tint_of(uint32_t reasons, float rgb[3])
{
    static const unsigned char tints[3][3] = {
        {VV_TINT_SEE_THROUGH_R, VV_TINT_SEE_THROUGH_G, VV_TINT_SEE_THROUGH_B},
        {VV_TINT_REFLECTION_R, VV_TINT_REFLECTION_G, VV_TINT_REFLECTION_B},
        {VV_TINT_SHADOW_R, VV_TINT_SHADOW_G, VV_TINT_SHADOW_B}};
    static const uint32_t bits[3] = {VIS_REASON_SEE_THROUGH, VIS_REASON_REFLECTION, VIS_REASON_SHADOW};
    if (reasons & VIS_REASON_DIRECT)
        return 0;
    for (int k = 0; k < 3; ++k)
        if (reasons & bits[k]) {
            for (int c = 0; c < 3; ++c)
                rgb[c] = (float)tints[k][c] / 255.0f;
            return k + 1;
        }
    return 0;
}

static int grow_ibo(vv_meshes *m, uint32_t quads)
{
    if (quads <= m->ibo_quads)
        return 0;
    uint32_t cap = m->ibo_quads ? m->ibo_quads : 1024;
    while (cap < quads)
        cap *= 2;
    uint32_t *idx = malloc((size_t)cap * 6 * sizeof *idx);
    if (!idx)
        return -1;
    for (uint32_t q = 0; q < cap; ++q) {
        uint32_t b = q * 4, *o = idx + (size_t)q * 6;
        o[0] = b, o[1] = b + 1, o[2] = b + 2, o[3] = b, o[4] = b + 2, o[5] = b + 3;
    }
    /* The same buffer name, so every VAO that references it sees the bigger one. */
    /* Through the copy target: the element binding is VAO state. */
    glBindBuffer(GL_COPY_WRITE_BUFFER, m->ibo);
    glBufferData(GL_COPY_WRITE_BUFFER, (GLsizeiptr)((size_t)cap * 6 * sizeof *idx), idx, GL_STATIC_DRAW);
    glBindBuffer(GL_COPY_WRITE_BUFFER, 0);
    free(idx);
    m->ibo_quads = cap;
    return 0;
}

static void upload(vv_meshes *m, uint32_t id, const vw_mesh *mesh)
{
    if (id < 1 || id > m->slots)
        return;
    vv_object *o = &m->obj[id - 1];
    if (o->quads) {
        m->total_quads -= o->quads;
        m->objects--;
    }
    o->quads = 0;
    if (mesh->count == 0)
        return;
    if (mesh->count * 4 > m->staging_cap) {
        size_t cap = mesh->count * 4 * 2;
        vv_vertex *s = realloc(m->staging, cap * sizeof *s);
        if (!s) {
            fprintf(stderr, "vis-viewer: out of memory for a mesh of %zu quads\n", mesh->count);
            m->failed = 1;
            return;
        }
        m->staging = s;
        m->staging_cap = cap;
    }
    if (grow_ibo(m, (uint32_t)mesh->count) != 0) {
        fprintf(stderr, "vis-viewer: out of memory for the index buffer\n");
        m->failed = 1;
        return;
    }
    float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
    for (size_t i = 0; i < mesh->count; ++i) {
        const vw_quad *q = &mesh->quads[i];
        const vw_material *mat = vw_world_material(m->world, q->material);
        uint32_t c = mat ? mat->rgba : 0xFFFF00FFu;
        int a = q->axis, u = (a + 1) % 3, v = (a + 2) % 3;
        uint8_t face = a == 1 ? (q->side > 0 ? 0 : 1) : a == 0 ? 2 : 3;
        const int32_t uv[4][2] = {{q->u0, q->v0}, {q->u1, q->v0}, {q->u1, q->v1}, {q->u0, q->v1}};
        for (int k = 0; k < 4; ++k) {
            vv_vertex *vx = &m->staging[i * 4 + k];
            vx->p[a] = (float)q->plane;
            vx->p[u] = (float)uv[k][0];
            vx->p[v] = (float)uv[k][1];
            vx->rgba[0] = (uint8_t)c, vx->rgba[1] = (uint8_t)(c >> 8), vx->rgba[2] = (uint8_t)(c >> 16);
            vx->rgba[3] = (uint8_t)(c >> 24);
            vx->face[0] = face;
            vx->face[1] = mat && (mat->flags & VW_MAT_SEE_THROUGH) ? 1 : 0;
            vx->face[2] = vx->face[3] = 0;
            for (int d = 0; d < 3; ++d) {
                lo[d] = vx->p[d] < lo[d] ? vx->p[d] : lo[d];
                hi[d] = vx->p[d] > hi[d] ? vx->p[d] : hi[d];
            }
        }
    }
    if (!o->vao) {
        glGenVertexArrays(1, &o->vao);
        glGenBuffers(1, &o->vbo);
        glBindVertexArray(o->vao);
        glBindBuffer(GL_ARRAY_BUFFER, o->vbo);
        glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, m->ibo);
        glEnableVertexAttribArray(0);
        glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(vv_vertex), (void *)offsetof(vv_vertex, p));
        glEnableVertexAttribArray(1);
        glVertexAttribPointer(1, 4, GL_UNSIGNED_BYTE, GL_TRUE, sizeof(vv_vertex), (void *)offsetof(vv_vertex, rgba));
        glEnableVertexAttribArray(2);
        glVertexAttribPointer(2, 4, GL_UNSIGNED_BYTE, GL_FALSE, sizeof(vv_vertex), (void *)offsetof(vv_vertex, face));
        glBindVertexArray(0);
    }
    glBindBuffer(GL_ARRAY_BUFFER, o->vbo);
    glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(mesh->count * 4 * sizeof(vv_vertex)), m->staging, GL_STATIC_DRAW);
    o->quads = (uint32_t)mesh->count;
    memcpy(o->lo, lo, sizeof lo);
    memcpy(o->hi, hi, sizeof hi);
    m->total_quads += o->quads;
    m->objects++;
}

void vv_meshes_chunk_hook(uint32_t chunk_index, uint32_t object_id, const vw_mesh *mesh, void *user)
{
    (void)chunk_index;
    upload(user, object_id, mesh);
}

vv_meshes *vv_meshes_create(world_scene *ws)
{
    vv_meshes *m = calloc(1, sizeof *m);
    if (!m) {
        fprintf(stderr, "vis-viewer: out of memory\n");
        return NULL;
    }
    m->world = world_scene_world(ws);
    vw_world_info wi;
    vw_world_get_info(m->world, &wi);
    m->slots = wi.chunk_count;
    m->obj = calloc(m->slots ? m->slots : 1, sizeof *m->obj);
    m->prog = vv_gl_program("mesh", vs_src, fs_src);
    if (!m->obj || !m->prog) {
        vv_meshes_destroy(m);
        return NULL;
    }
    m->u_mvp = glGetUniformLocation(m->prog, "mvp");
    m->u_shade = glGetUniformLocation(m->prog, "shade");
    m->u_tint = glGetUniformLocation(m->prog, "tint");
    m->u_door = glGetUniformLocation(m->prog, "door");
    glGenBuffers(1, &m->ibo);
    vw_error err;
    memset(&err, 0, sizeof err);
    if (world_scene_for_each_object(ws, vv_meshes_chunk_hook, m, &err) != 0 || m->failed) {
        fprintf(stderr, "vis-viewer: uploading the meshes: %s\n", err.message[0] ? err.message : "failed");
        vv_meshes_destroy(m);
        return NULL;
    }
    return m;
}

void vv_meshes_destroy(vv_meshes *m)
{
    if (!m)
        return;
    for (uint32_t i = 0; m->obj && i < m->slots; ++i) {
        if (m->obj[i].vao) {
            glDeleteVertexArrays(1, &m->obj[i].vao);
            glDeleteBuffers(1, &m->obj[i].vbo);
        }
    }
    if (m->ibo)
        glDeleteBuffers(1, &m->ibo);
    if (m->prog)
        glDeleteProgram(m->prog);
    free(m->obj);
    free(m->staging);
    free(m);
}

static uint64_t draw_one(vv_meshes *m, uint32_t id)
{
    if (id < 1 || id > m->slots)
        return 0;
    const vv_object *o = &m->obj[id - 1];
    if (!o->quads)
        return 0;
    glBindVertexArray(o->vao);
    glDrawElements(GL_TRIANGLES, (GLsizei)(o->quads * 6), GL_UNSIGNED_INT, NULL);
    return (uint64_t)o->quads * 2;
}

uint64_t vv_meshes_draw(vv_meshes *m, const vv_draw_desc *d, const float mvp[16])
{
    glUseProgram(m->prog);
    glUniformMatrix4fv(m->u_mvp, 1, GL_FALSE, mvp);
    glUniform4f(m->u_shade, VV_SHADE_TOP, VV_SHADE_BOTTOM, VV_SHADE_X, VV_SHADE_Z);
    glUniform4f(m->u_tint, 0.0f, 0.0f, 0.0f, 0.0f);
    glUniform1i(m->u_door, d->screen_door ? 1 : 0);
    uint64_t tris = 0;
    if (d->all) {
        for (uint32_t id = 1; id <= m->slots; ++id)
            tris += draw_one(m, id);
    } else {
        int tinted = 0;
        for (size_t i = 0; i < d->count; ++i) {
            float rgb[3];
            int t = d->reasons ? vv_tint_of(d->reasons[i].reasons, rgb) : 0;
            if (t)
                glUniform4f(m->u_tint, rgb[0], rgb[1], rgb[2], 1.0f);
            else if (tinted)
                glUniform4f(m->u_tint, 0.0f, 0.0f, 0.0f, 0.0f);
            tinted = t != 0;
            tris += draw_one(m, d->entries[i].id);
        }
    }
    glBindVertexArray(0);
    return tris;
}

uint64_t vv_meshes_total_triangles(const vv_meshes *m) { return m->total_quads * 2; }
uint32_t vv_meshes_objects(const vv_meshes *m) { return m->objects; }
uint32_t vv_meshes_max_id(const vv_meshes *m) { return m->slots; }

int vv_meshes_box(const vv_meshes *m, uint32_t id, float lo[3], float hi[3])
{
    if (id < 1 || id > m->slots || !m->obj[id - 1].quads)
        return 0;
    memcpy(lo, m->obj[id - 1].lo, 3 * sizeof *lo);
    memcpy(hi, m->obj[id - 1].hi, 3 * sizeof *hi);
    return 1;
}
