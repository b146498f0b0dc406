/*
 * vox_write.c — MagicaVoxel .vox export (version 200) of any world.
 *
 * Format: ephtracy/voxel-model, "MagicaVoxel-file-format-vox.txt" (chunks, SIZE, XYZI,
 * RGBA) and "MagicaVoxel-file-format-vox-extension.txt" (nTRN/nGRP/nSHP, MATL, LAYR).
 *
 * A .vox model holds at most 256 voxels per axis (XYZI coordinates are bytes), so the world
 * is cut into tiles of 256^3 aligned on its origin (a chunk edge divides 256, so every chunk
 * lies in one tile); each non-empty tile becomes one model, shrunk to its voxels' box, and
 * one shape under a translation in a single group:
 *     nTRN 0 -> nGRP 1 -> { nTRN 2k+2 (_t) -> nSHP 2k+3 (model k) }
 * The translation puts the model back where its voxels were, with the reader's placement
 * (vox_read.c): a voxel at p lands at t + p - floor(size/2), in .vox axes, which are the
 * world's (x, -z-1, y) (vw.h). Coordinates are absolute when they fit the int32 that _t
 * holds, else relative to the world's origin; loading the file gives back the same voxels at
 * the same coordinates (modulo that origin in the far case), with the same colours and
 * material flags.
 */
#include "vox_format.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "out_file.h"

#define TILE 256

/* A byte sink, a file or a growable buffer, that remembers the first failure. */
typedef struct vox_out {
    vwi_file *f;
    uint8_t *buf;
    size_t len, cap;
    vw_status status;
} vox_out;

static void out_bytes(vox_out *o, const void *p, size_t n)
{
    if (o->status != VW_OK || n == 0)
        return;
    if (o->f) {
        if (vwi_file_write(o->f, p, n) != 0)
            o->status = VW_ERROR_IO;
    } else {
        if (n > o->cap - o->len) {
            size_t cap = o->cap ? o->cap : 1 << 16;
            while (n > cap - o->len) {
                if (cap > SIZE_MAX / 2) {
                    o->status = VW_ERROR_OUT_OF_MEMORY;
                    return;
                }
                cap *= 2;
            }
            uint8_t *b = realloc(o->buf, cap);
            if (!b) {
                o->status = VW_ERROR_OUT_OF_MEMORY;
                return;
            }
            o->buf = b;
            o->cap = cap;
        }
        memcpy(o->buf + o->len, p, n);
    }
    o->len += n;
}

static void out_u32(vox_out *o, uint32_t v)
{
    const uint8_t b[4] = {(uint8_t)v, (uint8_t)(v >> 8), (uint8_t)(v >> 16), (uint8_t)(v >> 24)};
    out_bytes(o, b, 4);
}

static void out_i32(vox_out *o, int32_t v) { out_u32(o, (uint32_t)v); }

/* Overwrites 4 bytes written earlier (the MAIN chunk's children size). */
static void out_patch_u32(vox_out *o, size_t at, uint32_t v)
{
    if (o->status != VW_OK)
        return;
    const uint8_t b[4] = {(uint8_t)v, (uint8_t)(v >> 8), (uint8_t)(v >> 16), (uint8_t)(v >> 24)};
    if (o->f) {
        if (fseek(o->f->f, (long)at, SEEK_SET) != 0 || vwi_file_write(o->f, b, 4) != 0 ||
            fseek(o->f->f, 0, SEEK_END) != 0) {
            vwi_file_failed(o->f);
            o->status = VW_ERROR_IO;
        }
    } else {
        memcpy(o->buf + at, b, 4);
    }
}

static void out_chunk(vox_out *o, const char id[4], uint32_t content, uint32_t children)
{
    out_bytes(o, id, 4);
    out_u32(o, content);
    out_u32(o, children);
}

/* STRING and DICT (extension spec (a), (b)); keys and values are short literals here. */
static size_t dict_size(const char *const *kv, int pairs)
{
    size_t n = 4;
    for (int i = 0; i < 2 * pairs; i++)
        n += 4 + strlen(kv[i]);
    return n;
}

static void out_dict(vox_out *o, const char *const *kv, int pairs)
{
    out_i32(o, pairs);
    for (int i = 0; i < 2 * pairs; i++) {
        out_u32(o, (uint32_t)strlen(kv[i]));
        out_bytes(o, kv[i], strlen(kv[i]));
    }
}

/* One tile of the world: the box of its voxels (world coordinates, [lo, hi)) and count. */
typedef struct vox_tile {
    int64_t lo[3], hi[3];
    uint32_t count;
} vox_tile;

typedef struct vox_export {
    const vw_world *w;
    vw_world_info info;
    int32_t tiles[3];       /* per axis                                                      */
    vox_tile *tile;         /* tiles[0]*tiles[1]*tiles[2]                                    */
    int64_t base[3];        /* subtracted from world coordinates: 0, or the origin          */
} vox_export;

static size_t tile_of_chunk(const vox_export *e, const int32_t cc[3])
{
    int32_t per = TILE / e->info.chunk_size;
    return (size_t)(cc[0] / per) + (size_t)e->tiles[0] * ((size_t)(cc[1] / per) + (size_t)e->tiles[1] * (size_t)(cc[2] / per));
}

/* Calls fn for every solid voxel of a non-empty chunk. */
typedef void (*voxel_fn)(void *user, const int64_t p[3], vw_voxel v);

static void scan_chunk(const vox_export *e, uint32_t index, voxel_fn fn, void *user)
{
    int32_t cc[3];
    vw_world_chunk_coords(e->w, index, cc);
    int32_t C = e->info.chunk_size;
    int64_t p[3];
    for (int32_t z = 0; z < C; z++) {
        p[2] = e->info.origin[2] + (int64_t)cc[2] * C + z;
        for (int32_t y = 0; y < C; y++) {
            p[1] = e->info.origin[1] + (int64_t)cc[1] * C + y;
            for (int32_t x = 0; x < C; x++) {
                p[0] = e->info.origin[0] + (int64_t)cc[0] * C + x;
                vw_voxel v = vw_world_get(e->w, p[0], p[1], p[2]);
                if (v)
                    fn(user, p, v);
            }
        }
    }
}

static void measure_voxel(void *user, const int64_t p[3], vw_voxel v)
{
    (void)v;
    vox_tile *t = user;
    for (int a = 0; a < 3; a++) {
        if (t->count == 0 || p[a] < t->lo[a])
            t->lo[a] = p[a];
        if (t->count == 0 || p[a] + 1 > t->hi[a])
            t->hi[a] = p[a] + 1;
    }
    t->count++;
}

typedef struct vox_emit {
    vox_out *o;
    const vox_tile *t;
    uint8_t buf[4096];
    size_t n;
} vox_emit;

/* World (X, Y, Z) to the model's (x, y, z): .vox x = X, y = -Z-1, z = Y, relative to the
 * model's min corner (lo0, -hi2, lo1). */
static void emit_voxel(void *user, const int64_t p[3], vw_voxel v)
{
    vox_emit *m = user;
    uint8_t *b = m->buf + m->n;
    b[0] = (uint8_t)(p[0] - m->t->lo[0]);
    b[1] = (uint8_t)(m->t->hi[2] - 1 - p[2]);
    b[2] = (uint8_t)(p[1] - m->t->lo[1]);
    b[3] = v;
    m->n += 4;
    if (m->n == sizeof m->buf) {
        out_bytes(m->o, m->buf, m->n);
        m->n = 0;
    }
}

static void int_text(char *out, size_t cap, int64_t a, int64_t b, int64_t c)
{
    snprintf(out, cap, "%lld %lld %lld", (long long)a, (long long)b, (long long)c);
}

static vw_status write_vox(const vw_world *w, vox_out *o, vw_error *err)
{
    vox_export e;
    memset(&e, 0, sizeof e);
    e.w = w;
    vw_world_get_info(w, &e.info);
    size_t ntiles = 1;
    for (int a = 0; a < 3; a++) {
        e.tiles[a] = (e.info.size[a] + TILE - 1) / TILE;
        ntiles *= (size_t)e.tiles[a];
    }
    e.tile = calloc(ntiles, sizeof *e.tile);
    if (!e.tile) {
        if (err)
            snprintf(err->message, sizeof err->message, ".vox export: out of memory for %zu tiles", ntiles);
        return VW_ERROR_OUT_OF_MEMORY;
    }

    /* Pass 1: each tile's voxel box and count, visiting only non-empty chunks. */
    int64_t lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
    uint32_t models = 0;
    for (uint32_t i = 0; i < e.info.chunk_count; i++) {
        if (vw_world_chunk_empty(w, i))
            continue;
        int32_t cc[3];
        vw_world_chunk_coords(w, i, cc);
        scan_chunk(&e, i, measure_voxel, &e.tile[tile_of_chunk(&e, cc)]);
    }
    for (size_t t = 0; t < ntiles; t++) {
        if (!e.tile[t].count)
            continue;
        for (int a = 0; a < 3; a++) {
            if (models == 0 || e.tile[t].lo[a] < lo[a])
                lo[a] = e.tile[t].lo[a];
            if (models == 0 || e.tile[t].hi[a] > hi[a])
                hi[a] = e.tile[t].hi[a];
        }
        models++;
    }
    /* _t is an int32 string; a world far from 0 is written relative to its origin. */
    const int64_t lim = ((int64_t)1 << 31) - 2 * TILE;
    int far = 0;
    for (int a = 0; a < 3; a++)
        far |= lo[a] < -lim || hi[a] > lim;
    for (int a = 0; a < 3; a++)
        e.base[a] = far ? e.info.origin[a] : 0;

    /* Header and MAIN (format spec section 1, 3); MAIN's children size is patched last. */
    out_bytes(o, "VOX ", 4);
    out_u32(o, 200);
    out_chunk(o, "MAIN", 0, 0);
    size_t main_children = o->len - 4, main_start = o->len;

    if (models == 0) {
        /* MagicaVoxel wants a model; an empty 1x1x1 one loads as an empty world. */
        out_chunk(o, "SIZE", 12, 0);
        out_i32(o, 1), out_i32(o, 1), out_i32(o, 1);
        out_chunk(o, "XYZI", 4, 0);
        out_u32(o, 0);
    }
    /* Pass 2: SIZE + XYZI per non-empty tile (format spec sections 5, 6). */
    for (size_t t = 0; t < ntiles && o->status == VW_OK; t++) {
        const vox_tile *tl = &e.tile[t];
        if (!tl->count)
            continue;
        out_chunk(o, "SIZE", 12, 0);
        out_i32(o, (int32_t)(tl->hi[0] - tl->lo[0]));
        out_i32(o, (int32_t)(tl->hi[2] - tl->lo[2]));
        out_i32(o, (int32_t)(tl->hi[1] - tl->lo[1]));
        out_chunk(o, "XYZI", 4 + 4 * tl->count, 0);
        out_u32(o, tl->count);
        vox_emit m;
        m.o = o;
        m.t = tl;
        m.n = 0;
        int32_t per = TILE / e.info.chunk_size;
        int32_t tc[3] = {(int32_t)(t % (size_t)e.tiles[0]), (int32_t)(t / (size_t)e.tiles[0] % (size_t)e.tiles[1]),
                         (int32_t)(t / (size_t)e.tiles[0] / (size_t)e.tiles[1])};
        for (int32_t cz = tc[2] * per; cz < (tc[2] + 1) * per && cz < e.info.chunks[2]; cz++)
            for (int32_t cy = tc[1] * per; cy < (tc[1] + 1) * per && cy < e.info.chunks[1]; cy++)
                for (int32_t cx = tc[0] * per; cx < (tc[0] + 1) * per && cx < e.info.chunks[0]; cx++) {
                    uint32_t i = vw_world_chunk_index(w, cx, cy, cz);
                    if (!vw_world_chunk_empty(w, i))
                        scan_chunk(&e, i, emit_voxel, &m);
                }
        out_bytes(o, m.buf, m.n);
    }

    /* Scene graph (extension spec (d), (1)-(3)). */
    if (models > 0) {
        static const char *const none[1] = {NULL};
        out_chunk(o, "nTRN", (uint32_t)(4 + dict_size(none, 0) + 16 + dict_size(none, 0)), 0);
        out_i32(o, 0);
        out_dict(o, none, 0);
        out_i32(o, 1), out_i32(o, -1), out_i32(o, -1), out_i32(o, 1);
        out_dict(o, none, 0);

        out_chunk(o, "nGRP", (uint32_t)(4 + dict_size(none, 0) + 4 + 4 * (size_t)models), 0);
        out_i32(o, 1);
        out_dict(o, none, 0);
        out_i32(o, (int32_t)models);
        for (uint32_t k = 0; k < models; k++)
            out_i32(o, (int32_t)(2 + 2 * k));

        uint32_t k = 0;
        for (size_t t = 0; t < ntiles && o->status == VW_OK; t++) {
            const vox_tile *tl = &e.tile[t];
            if (!tl->count)
                continue;
            /* Model min corner in .vox axes, then + floor(size/2): the reader's pivot. */
            int64_t vmin[3] = {tl->lo[0] - e.base[0], -(tl->hi[2] - e.base[2]), tl->lo[1] - e.base[1]};
            int64_t vsize[3] = {tl->hi[0] - tl->lo[0], tl->hi[2] - tl->lo[2], tl->hi[1] - tl->lo[1]};
            char tr[64];
            int_text(tr, sizeof tr, vmin[0] + vsize[0] / 2, vmin[1] + vsize[1] / 2, vmin[2] + vsize[2] / 2);
            const char *const frame[2] = {"_t", tr};
            out_chunk(o, "nTRN", (uint32_t)(4 + dict_size(none, 0) + 16 + dict_size(frame, 1)), 0);
            out_i32(o, (int32_t)(2 + 2 * k));
            out_dict(o, none, 0);
            out_i32(o, (int32_t)(3 + 2 * k)), out_i32(o, -1), out_i32(o, 0), out_i32(o, 1);
            out_dict(o, frame, 1);

            out_chunk(o, "nSHP", (uint32_t)(4 + dict_size(none, 0) + 4 + 4 + dict_size(none, 0)), 0);
            out_i32(o, (int32_t)(3 + 2 * k));
            out_dict(o, none, 0);
            out_i32(o, 1);
            out_i32(o, (int32_t)k);
            out_dict(o, none, 0);
            k++;
        }
        /* Layer 0, which the shapes' transforms name. */
        static const char *const layer[2] = {"_name", "0"};
        out_chunk(o, "LAYR", (uint32_t)(4 + dict_size(layer, 1) + 4), 0);
        out_i32(o, 0);
        out_dict(o, layer, 1);
        out_i32(o, -1);
    }

    /* Palette (format spec section 7): entry i is colour index i + 1. */
    out_chunk(o, "RGBA", 1024, 0);
    for (uint32_t i = 1; i <= 256; i++)
        out_u32(o, i < 256 ? vw_world_material(w, i)->rgba : 0);

    /* Materials that are not plain opaque: _glass for see-through, a smooth _metal for a
     * mirror (what vox_read.c maps back to those flags; docs/vox.md), and _vw_flags with our
     * exact flags, which MagicaVoxel ignores and vox_read.c honours. */
    for (uint32_t i = 1; i < 256; i++) {
        uint32_t f = vw_world_material(w, i)->flags;
        if (!(f & (VW_MAT_SEE_THROUGH | VW_MAT_REFLECTIVE)))
            continue;
        char fl[8];
        snprintf(fl, sizeof fl, "%u", (unsigned)(f & (VW_MAT_OPAQUE | VW_MAT_SEE_THROUGH | VW_MAT_REFLECTIVE)));
        const char *const glass[6] = {"_type", "_glass", "_trans", "0.5", "_vw_flags", fl};
        const char *const metal[8] = {"_type", "_metal", "_metal", "1", "_rough", "0.1", "_vw_flags", fl};
        const char *const *kv = (f & VW_MAT_SEE_THROUGH) ? glass : metal;
        int pairs = (f & VW_MAT_SEE_THROUGH) ? 3 : 4;
        out_chunk(o, "MATL", (uint32_t)(4 + dict_size(kv, pairs)), 0);
        out_i32(o, (int32_t)i);
        out_dict(o, kv, pairs);
    }

    size_t total = o->len - main_start;
    if (o->status == VW_OK && total > 0x7FFFFFFFu) {
        if (err)
            snprintf(err->message, sizeof err->message, ".vox export: %zu bytes exceed the format's 2 GiB", total);
        free(e.tile);
        return VW_ERROR_UNSUPPORTED;
    }
    out_patch_u32(o, main_children, (uint32_t)total);
    free(e.tile);
    if (o->status != VW_OK && err)
        snprintf(err->message, sizeof err->message, ".vox export: %s",
                 o->status == VW_ERROR_IO ? "write failed" : "out of memory");
    return o->status;
}

vw_status vw_vox_save_memory(const vw_world *world, void **out_data, size_t *out_size, vw_error *err)
{
    if (!world || !out_data || !out_size)
        return VW_ERROR_INVALID_ARGUMENT;
    *out_data = NULL;
    *out_size = 0;
    vox_out o;
    memset(&o, 0, sizeof o);
    vw_status s = write_vox(world, &o, err);
    if (s != VW_OK) {
        free(o.buf);
        return s;
    }
    *out_data = o.buf;
    *out_size = o.len;
    return VW_OK;
}

vw_status vw_vox_save_file(const vw_world *world, const char *path, vw_error *err)
{
    if (!world || !path)
        return VW_ERROR_INVALID_ARGUMENT;
    /* Through out_file.h: a failed export leaves what was at PATH as it was, and no partial
     * file (removing PATH instead once deleted /dev/full for a root user). */
    vwi_file file;
    vw_status s = vwi_out_open(&file, path, err);
    if (s != VW_OK)
        return s;
    vox_out o;
    memset(&o, 0, sizeof o);
    o.f = &file;
    return vwi_out_close(&file, write_vox(world, &o, err), err);
}
