/* world.c — chunked voxel storage: create/destroy, materials, get/set/fill, dirty chunks.
 *
 * Storage is described in vw_internal.h: a flat table of chunks, each uniform (no memory) or
 * dense (C^3 bytes). Writes convert a uniform chunk to dense lazily, and a chunk that becomes
 * uniform again (all air after a dig, one material after a fill) is compacted back, so memory
 * follows the number of chunks that actually mix materials.
 *
 * Budget: a world never holds more than its max_bytes (vw_world_desc). The chunk table is
 * checked arithmetically before it is allocated, and every dense chunk is charged before its
 * malloc; an edit that would pass the limit fails with VW_ERROR_BUDGET before it changes
 * anything. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vw_internal.h"

vw_status vwi_fail(vw_error *err, vw_status status, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->message, sizeof err->message, fmt, ap);
        va_end(ap);
    }
    return status;
}

const char *vw_status_string(vw_status status)
{
    switch (status) {
    case VW_OK: return "ok";
    case VW_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case VW_ERROR_OUT_OF_MEMORY: return "out of memory";
    case VW_ERROR_IO: return "i/o error";
    case VW_ERROR_FORMAT: return "malformed data";
    case VW_ERROR_UNSUPPORTED: return "unsupported";
    case VW_ERROR_RANGE: return "coordinate outside the world";
    case VW_ERROR_BUDGET: return "over budget";
    }
    return "unknown status";
}

/* ---- accounting --------------------------------------------------------------------- */

/* Every change to a chunk goes through remove/add of its contribution to the totals, so
 * vw_world_get_info never has to scan. */
static void account_remove(vw_world *w, const vwi_chunk *c)
{
    w->nonempty_chunks -= c->solid != 0;
    w->dense_chunks -= c->voxels != NULL;
    w->heap_chunks -= c->voxels != NULL && !c->pooled;
    w->solid_voxels -= c->solid;
}

static void account_add(vw_world *w, const vwi_chunk *c)
{
    w->nonempty_chunks += c->solid != 0;
    w->dense_chunks += c->voxels != NULL;
    w->heap_chunks += c->voxels != NULL && !c->pooled;
    w->solid_voxels += c->solid;
}

const char *vwi_format_bytes(uint64_t bytes, char *buf, size_t size)
{
    static const char *const unit[] = {"KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
    if (bytes < 1024) {
        snprintf(buf, size, "%llu bytes", (unsigned long long)bytes);
        return buf;
    }
    double v = (double)bytes / 1024.0;
    int u = 0;
    while (v >= 1024.0 && u < 5)
        v /= 1024.0, u++;
    snprintf(buf, size, "%.1f %s", v, unit[u]);
    return buf;
}

const char *vwi_format_count(uint64_t count, char *buf, size_t size)
{
    char digits[24];
    int n = snprintf(digits, sizeof digits, "%llu", (unsigned long long)count);
    size_t k = 0;
    for (int i = 0; i < n && k + 2 < size; i++) {
        if (i > 0 && (n - i) % 3 == 0)
            buf[k++] = ',';
        buf[k++] = digits[i];
    }
    buf[k] = '\0';
    return buf;
}

vw_status vwi_dense_failure(const vw_world *w)
{
    return vwi_world_bytes(w) + vwi_chunk_volume(w) > w->max_bytes ? VW_ERROR_BUDGET : VW_ERROR_OUT_OF_MEMORY;
}

uint8_t *vwi_chunk_dense(vw_world *w, uint32_t index)
{
    vwi_chunk *c = &w->chunk[index];
    if (!c->voxels) {
        /* The pool first: a given-back array costs nothing, a new block is charged whole. */
        uint8_t *v = vwi_pool_take(w);
        const int pooled = v != NULL;
        if (!v) {
            if (vwi_world_bytes(w) + vwi_chunk_volume(w) > w->max_bytes)
                return NULL;
            v = malloc(vwi_chunk_volume(w));
            if (!v)
                return NULL;
        }
        memset(v, c->uniform, vwi_chunk_volume(w));
        account_remove(w, c);
        c->voxels = v;
        c->pooled = (uint8_t)pooled;
        account_add(w, c);
    }
    return c->voxels;
}

void vwi_chunk_set_uniform(vw_world *w, uint32_t index, uint8_t value)
{
    vwi_chunk *c = &w->chunk[index];
    account_remove(w, c);
    if (c->pooled)
        vwi_pool_give(w, c->voxels);
    else
        free(c->voxels);
    c->voxels = NULL;
    c->pooled = 0;
    c->uniform = value;
    c->solid = value ? vwi_chunk_volume(w) : 0;
    account_add(w, c);
}

void vwi_chunk_set_solid(vw_world *w, uint32_t index, uint32_t solid)
{
    vwi_chunk *c = &w->chunk[index];
    account_remove(w, c);
    c->solid = solid;
    account_add(w, c);
}

void vwi_chunk_settle(vw_world *w, uint32_t index)
{
    vwi_chunk *c = &w->chunk[index];
    if (!c->voxels)
        return;
    const uint8_t *v = c->voxels;
    uint32_t n = vwi_chunk_volume(w), solid = 0;
    for (uint32_t i = 0; i < n; i++)
        solid += v[i] != 0;
    account_remove(w, c);
    c->solid = solid;
    account_add(w, c);
    if (solid == 0) {
        vwi_chunk_set_uniform(w, index, 0);
    } else if (solid == n) {
        uint32_t i = 1;
        while (i < n && v[i] == v[0])
            i++;
        if (i == n)
            vwi_chunk_set_uniform(w, index, v[0]);
    }
}

/* ---- create / destroy / info -------------------------------------------------------- */

/* The default palette: a 6x7x6 colour cube, so that neighbouring indices differ visibly. */
static uint32_t palette_colour(uint32_t i)
{
    uint32_t c = (i - 1) % 252;
    uint32_t r = (c % 6) * 51, g = ((c / 6) % 7) * 42, b = (c / 42) * 51;
    return 0xFF000000u | (b << 16) | (g << 8) | r;
}

vw_status vw_world_create(const vw_world_desc *desc, vw_world **out_world, vw_error *err)
{
    if (!desc || !out_world)
        return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "vw_world_create: desc and out_world must not be NULL");
    *out_world = NULL;
    int32_t cs = desc->chunk_size ? desc->chunk_size : 16;
    if (cs != 16 && cs != 32)
        return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "chunk size %d: must be 16 or 32", (int)cs);
    int32_t chunks[3];
    uint64_t count = 1;
    for (int a = 0; a < 3; a++) {
        if (desc->size[a] <= 0 || desc->size[a] > VWI_MAX_AXIS)
            return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "world size %d on axis %c: must be in 1..%d voxels",
                            (int)desc->size[a], "xyz"[a], VWI_MAX_AXIS);
        if (desc->origin[a] % cs != 0)
            return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "origin %lld on axis %c is not a multiple of the chunk size %d",
                            (long long)desc->origin[a], "xyz"[a], (int)cs);
        if (desc->origin[a] < -VWI_MAX_ORIGIN || desc->origin[a] > VWI_MAX_ORIGIN)
            return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "origin %lld on axis %c is beyond +-2^60",
                            (long long)desc->origin[a], "xyz"[a]);
        chunks[a] = (desc->size[a] + cs - 1) / cs;
        count *= (uint64_t)chunks[a];
    }
    if (count > VWI_MAX_CHUNKS)
        return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "world of %dx%dx%d voxels has %llu chunks; at most %u are allowed",
                        (int)desc->size[0], (int)desc->size[1], (int)desc->size[2], (unsigned long long)count,
                        (unsigned)VWI_MAX_CHUNKS);
    const uint64_t limit = desc->max_bytes ? desc->max_bytes : VW_DEFAULT_MAX_BYTES;
    const uint64_t need = vwi_table_bytes(count);
    if (need > limit) {
        char a[32], b[32], n[32];
        return vwi_fail(err, VW_ERROR_BUDGET,
                        "world of %dx%dx%d voxels needs %s for its table of %s chunks; the budget is %s",
                        (int)desc->size[0], (int)desc->size[1], (int)desc->size[2], vwi_format_bytes(need, a, sizeof a),
                        vwi_format_count(count, n, sizeof n), vwi_format_bytes(limit, b, sizeof b));
    }

    vw_world *w = calloc(1, sizeof *w);
    if (!w)
        return vwi_fail(err, VW_ERROR_OUT_OF_MEMORY, "out of memory for the world");
    w->chunk_size = cs;
    w->chunk_shift = cs == 16 ? 4 : 5;
    w->chunk_count = (uint32_t)count;
    w->max_bytes = limit;
    for (int a = 0; a < 3; a++) {
        w->origin[a] = desc->origin[a];
        w->chunks[a] = chunks[a];
        w->size[a] = chunks[a] * cs;
    }
    w->chunk = calloc(count, sizeof *w->chunk);
    w->dirty = calloc((count + 63) / 64, sizeof *w->dirty);
    w->dirty_any = calloc(((count + 63) / 64 + 63) / 64, sizeof *w->dirty_any);
    if (!w->chunk || !w->dirty || !w->dirty_any) {
        vw_world_destroy(w);
        return vwi_fail(err, VW_ERROR_OUT_OF_MEMORY, "out of memory for a table of %llu chunks", (unsigned long long)count);
    }
    for (uint32_t i = 1; i < 256; i++) {
        w->material[i].rgba = palette_colour(i);
        w->material[i].flags = VW_MAT_OPAQUE;
    }
    *out_world = w;
    return VW_OK;
}

void vw_world_destroy(vw_world *w)
{
    if (!w)
        return;
    if (w->chunk)
        for (uint32_t i = 0; i < w->chunk_count; i++)
            if (!w->chunk[i].pooled)
                free(w->chunk[i].voxels);
    vwi_pool_destroy(w);
    free(w->chunk);
    free(w->dirty);
    free(w->dirty_any);
    free(w);
}

void vw_world_get_info(const vw_world *w, vw_world_info *out)
{
    if (!w || !out)
        return;
    memset(out, 0, sizeof *out);
    out->chunk_size = w->chunk_size;
    for (int a = 0; a < 3; a++) {
        out->origin[a] = w->origin[a];
        out->size[a] = w->size[a];
        out->chunks[a] = w->chunks[a];
    }
    out->chunk_count = w->chunk_count;
    out->nonempty_chunks = w->nonempty_chunks;
    out->solid_voxels = w->solid_voxels;
    out->bytes = vwi_world_bytes(w);
    out->max_bytes = w->max_bytes;
}

/* ---- materials ---------------------------------------------------------------------- */

vw_status vw_world_set_material(vw_world *w, uint32_t index, const vw_material *m)
{
    if (!w || !m || index == 0 || index > 255)
        return VW_ERROR_INVALID_ARGUMENT;
    /* Normalise so that exactly one of OPAQUE / SEE_THROUGH is set: the mesher and the
     * quads' flags then need no "neither" or "both" case. */
    uint32_t flags = m->flags & (VW_MAT_OPAQUE | VW_MAT_SEE_THROUGH | VW_MAT_REFLECTIVE);
    flags = (flags & VW_MAT_SEE_THROUGH) ? (flags & ~VW_MAT_OPAQUE) : (flags | VW_MAT_OPAQUE);
    if (flags != w->material[index].flags) {
        /* Faces and quad flags depend on the flags: every mesh that may hold the material is
         * stale. (A colour change alters no quad.) */
        for (uint32_t i = 0; i < w->chunk_count; i++)
            if (w->chunk[i].solid)
                vwi_mark_dirty(w, i);
    }
    w->material[index].rgba = m->rgba;
    w->material[index].flags = flags;
    return VW_OK;
}

const vw_material *vw_world_material(const vw_world *w, uint32_t index)
{
    if (!w || index > 255)
        return NULL;
    return &w->material[index];
}

/* ---- voxels ------------------------------------------------------------------------- */

/* Relative coordinates via unsigned wrap-around: one compare per axis rejects both sides,
 * and no int64 subtraction can overflow however far the point is. */
static int locate(const vw_world *w, int64_t x, int64_t y, int64_t z, uint32_t rel[3])
{
    const int64_t p[3] = {x, y, z};
    for (int a = 0; a < 3; a++) {
        uint64_t d = (uint64_t)p[a] - (uint64_t)w->origin[a];
        if (d >= (uint64_t)w->size[a])
            return 0;
        rel[a] = (uint32_t)d;
    }
    return 1;
}

vw_voxel vw_world_get(const vw_world *w, int64_t x, int64_t y, int64_t z)
{
    uint32_t r[3];
    if (!w || !locate(w, x, y, z, r))
        return 0;
    int s = w->chunk_shift;
    uint32_t m = (uint32_t)w->chunk_size - 1;
    const vwi_chunk *c = &w->chunk[vwi_index(w, (int32_t)(r[0] >> s), (int32_t)(r[1] >> s), (int32_t)(r[2] >> s))];
    if (!c->voxels)
        return c->uniform;
    return c->voxels[(r[0] & m) + ((r[1] & m) << s) + ((r[2] & m) << (2 * s))];
}

int vw_world_box_opaque(const vw_world *w, const int64_t min[3], const int64_t max[3])
{
    if (!w || !min || !max)
        return 0;
    uint32_t lo[3], hi[3]; /* relative, [lo, hi) */
    for (int a = 0; a < 3; a++) {
        if (!(min[a] < max[a]))
            return 0;
        uint64_t d0 = (uint64_t)min[a] - (uint64_t)w->origin[a], d1 = (uint64_t)max[a] - 1u - (uint64_t)w->origin[a];
        if (d0 >= (uint64_t)w->size[a] || d1 >= (uint64_t)w->size[a])
            return 0; /* reaches outside the world, which is empty */
        lo[a] = (uint32_t)d0;
        hi[a] = (uint32_t)d1 + 1u;
    }
    const int s = w->chunk_shift;
    const uint32_t m = (uint32_t)w->chunk_size - 1;
    /* Chunk by chunk: a uniform chunk answers for all its voxels at once. */
    for (uint32_t cz = lo[2] >> s; cz <= (hi[2] - 1) >> s; cz++)
        for (uint32_t cy = lo[1] >> s; cy <= (hi[1] - 1) >> s; cy++)
            for (uint32_t cx = lo[0] >> s; cx <= (hi[0] - 1) >> s; cx++) {
                const vwi_chunk *c = &w->chunk[vwi_index(w, (int32_t)cx, (int32_t)cy, (int32_t)cz)];
                if (!c->voxels) {
                    if (!c->uniform || (w->material[c->uniform].flags & VW_MAT_SEE_THROUGH))
                        return 0;
                    continue;
                }
                const uint32_t c0[3] = {cx << s, cy << s, cz << s};
                uint32_t b0[3], b1[3]; /* the box inside this chunk, chunk-relative */
                const uint32_t cc[3] = {cx, cy, cz};
                for (int a = 0; a < 3; a++) {
                    b0[a] = (cc[a] << s) > lo[a] ? 0u : lo[a] & m;
                    b1[a] = ((cc[a] + 1u) << s) < hi[a] ? m + 1u : hi[a] - c0[a];
                }
                for (uint32_t z = b0[2]; z < b1[2]; z++)
                    for (uint32_t y = b0[1]; y < b1[1]; y++) {
                        const uint8_t *row = c->voxels + (y << s) + (z << (2 * s));
                        for (uint32_t x = b0[0]; x < b1[0]; x++)
                            if (!row[x] || (w->material[row[x]].flags & VW_MAT_SEE_THROUGH))
                                return 0;
                    }
            }
    return 1;
}

void vwi_mark_dirty(vw_world *w, uint32_t i)
{
    uint64_t bit = 1ull << (i & 63);
    if (!(w->dirty[i >> 6] & bit)) {
        w->dirty[i >> 6] |= bit;
        w->dirty_any[i >> 12] |= 1ull << ((i >> 6) & 63);
        w->dirty_count++;
    }
}

vw_status vw_world_set(vw_world *w, int64_t x, int64_t y, int64_t z, vw_voxel value)
{
    uint32_t r[3];
    if (!w)
        return VW_ERROR_INVALID_ARGUMENT;
    if (!locate(w, x, y, z, r))
        return VW_ERROR_RANGE;
    int s = w->chunk_shift;
    uint32_t m = (uint32_t)w->chunk_size - 1;
    int32_t cc[3] = {(int32_t)(r[0] >> s), (int32_t)(r[1] >> s), (int32_t)(r[2] >> s)};
    uint32_t index = vwi_index(w, cc[0], cc[1], cc[2]);
    vwi_chunk *c = &w->chunk[index];
    if (c->voxels || c->uniform != value) {
        uint8_t *v = vwi_chunk_dense(w, index);
        if (!v)
            return vwi_dense_failure(w); /* nothing changed yet */
        uint8_t *p = &v[(r[0] & m) + ((r[1] & m) << s) + ((r[2] & m) << (2 * s))];
        account_remove(w, c);
        c->solid = c->solid + (value != 0) - (*p != 0);
        *p = value;
        account_add(w, c);
        if (c->solid == 0 || c->solid == vwi_chunk_volume(w))
            vwi_chunk_settle(w, index); /* compact a chunk that may have become uniform */
    }
    /* Marked even when nothing changed: a spurious remesh is harmless, a missed one is not. */
    vwi_mark_dirty(w, index);
    /* A voxel on a chunk face also shapes the faces of the chunk across it. */
    for (int a = 0; a < 3; a++) {
        uint32_t l = r[a] & m;
        int32_t n[3] = {cc[0], cc[1], cc[2]};
        if (l == 0 && cc[a] > 0) {
            n[a] = cc[a] - 1;
            vwi_mark_dirty(w, vwi_index(w, n[0], n[1], n[2]));
        } else if (l == m && cc[a] + 1 < w->chunks[a]) {
            n[a] = cc[a] + 1;
            vwi_mark_dirty(w, vwi_index(w, n[0], n[1], n[2]));
        }
    }
    return VW_OK;
}

/* Clips [min, max) to the world on one axis; 0 when nothing is left. */
static int clip_axis(const vw_world *w, int a, int64_t min, int64_t max, int32_t *lo, int32_t *hi)
{
    int64_t o = w->origin[a], end = o + w->size[a];
    if (max <= o || min >= end || min >= max)
        return 0;
    *lo = (int32_t)(min <= o ? 0 : min - o);
    *hi = (int32_t)(max >= end ? w->size[a] : max - o);
    return 1;
}

static void mark_range(vw_world *w, const int32_t c0[3], const int32_t c1[3])
{
    for (int32_t z = c0[2]; z <= c1[2]; z++)
        for (int32_t y = c0[1]; y <= c1[1]; y++)
            for (int32_t x = c0[0]; x <= c1[0]; x++)
                vwi_mark_dirty(w, vwi_index(w, x, y, z));
}

vw_status vw_world_fill(vw_world *w, const int64_t min[3], const int64_t max[3], vw_voxel value)
{
    if (!w || !min || !max)
        return VW_ERROR_INVALID_ARGUMENT;
    int32_t lo[3], hi[3], c0[3], c1[3];
    for (int a = 0; a < 3; a++)
        if (!clip_axis(w, a, min[a], max[a], &lo[a], &hi[a]))
            return VW_OK;
    const int s = w->chunk_shift;
    const int32_t cs = w->chunk_size;
    for (int a = 0; a < 3; a++) {
        c0[a] = lo[a] >> s;
        c1[a] = (hi[a] - 1) >> s;
    }
    /* The budget first, so that a fill over it changes nothing: the chunks the box covers in
     * part and that are uniform with another value each need a dense array. (Whole chunks
     * become uniform, which only frees memory; that is not counted, so the check may refuse
     * a fill that would have fitted in this order, never admit one that does not.) */
    uint64_t need = 0;
    for (int32_t cz = c0[2]; cz <= c1[2]; cz++)
        for (int32_t cy = c0[1]; cy <= c1[1]; cy++)
            for (int32_t cx = c0[0]; cx <= c1[0]; cx++) {
                const int32_t cc[3] = {cx, cy, cz};
                int whole = 1;
                for (int a = 0; a < 3; a++)
                    whole &= lo[a] <= (cc[a] << s) && hi[a] >= (cc[a] << s) + cs;
                const vwi_chunk *c = &w->chunk[vwi_index(w, cx, cy, cz)];
                need += !whole && !c->voxels && c->uniform != value;
            }
    if (vwi_world_bytes(w) + need * vwi_chunk_volume(w) > w->max_bytes)
        return VW_ERROR_BUDGET;
    vw_status st = VW_OK;
    for (int32_t cz = c0[2]; cz <= c1[2] && st == VW_OK; cz++)
        for (int32_t cy = c0[1]; cy <= c1[1] && st == VW_OK; cy++)
            for (int32_t cx = c0[0]; cx <= c1[0]; cx++) {
                const int32_t cc[3] = {cx, cy, cz};
                int32_t l0[3], l1[3], whole = 1;
                for (int a = 0; a < 3; a++) {
                    int32_t base = cc[a] << s;
                    l0[a] = lo[a] > base ? lo[a] - base : 0;
                    l1[a] = hi[a] < base + cs ? hi[a] - base : cs;
                    whole &= l0[a] == 0 && l1[a] == cs;
                }
                uint32_t index = vwi_index(w, cx, cy, cz);
                vwi_chunk *c = &w->chunk[index];
                if (whole) {
                    vwi_chunk_set_uniform(w, index, value);
                    continue;
                }
                if (!c->voxels && c->uniform == value)
                    continue;
                uint8_t *v = vwi_chunk_dense(w, index);
                if (!v) {
                    /* malloc failed (the budget was checked above): what was filled so far
                     * stays, and is marked dirty below like a whole fill. */
                    st = vwi_dense_failure(w);
                    break;
                }
                for (int32_t z = l0[2]; z < l1[2]; z++)
                    for (int32_t y = l0[1]; y < l1[1]; y++)
                        memset(v + l0[0] + ((y + (z << s)) << s), value, (size_t)(l1[0] - l0[0]));
                vwi_chunk_settle(w, index);
            }
    /* Dirty: the chunks the box touches, and across each box face that lies on a chunk
     * border, the chunks on the other side (only along that axis: faces look along axes). */
    mark_range(w, c0, c1);
    for (int a = 0; a < 3; a++) {
        int32_t n0[3] = {c0[0], c0[1], c0[2]}, n1[3] = {c1[0], c1[1], c1[2]};
        if ((lo[a] & (cs - 1)) == 0 && c0[a] > 0) {
            n0[a] = n1[a] = c0[a] - 1;
            mark_range(w, n0, n1);
        }
        n0[a] = c0[a];
        n1[a] = c1[a];
        if ((hi[a] & (cs - 1)) == 0 && c1[a] + 1 < w->chunks[a]) {
            n0[a] = n1[a] = c1[a] + 1;
            mark_range(w, n0, n1);
        }
    }
    return st;
}

/* ---- chunks ------------------------------------------------------------------------- */

uint32_t vw_world_chunk_index(const vw_world *w, int32_t cx, int32_t cy, int32_t cz)
{
    if (!w || cx < 0 || cy < 0 || cz < 0 || cx >= w->chunks[0] || cy >= w->chunks[1] || cz >= w->chunks[2])
        return UINT32_MAX;
    return vwi_index(w, cx, cy, cz);
}

void vw_world_chunk_coords(const vw_world *w, uint32_t i, int32_t out_c[3])
{
    if (!w || !out_c)
        return;
    uint32_t nx = (uint32_t)w->chunks[0], ny = (uint32_t)w->chunks[1];
    out_c[0] = (int32_t)(i % nx);
    out_c[1] = (int32_t)(i / nx % ny);
    out_c[2] = (int32_t)(i / nx / ny);
}

int vw_world_chunk_empty(const vw_world *w, uint32_t i)
{
    return !w || i >= w->chunk_count || w->chunk[i].solid == 0;
}

/* ---- dirty chunks ------------------------------------------------------------------- */

size_t vw_world_take_dirty(vw_world *w, uint32_t *out, size_t capacity)
{
    if (!w)
        return 0;
    if (!out || capacity == 0)
        return w->dirty_count;
    size_t n = 0, summary = (((size_t)w->chunk_count + 63) / 64 + 63) / 64;
    for (size_t j = 0; j < summary && n < capacity; j++)
        for (uint64_t words = w->dirty_any[j]; words && n < capacity; words &= words - 1) {
            const size_t k = j * 64 + (size_t)vwi_ctz64(words);
            uint64_t bits = w->dirty[k];
            for (; bits && n < capacity; bits &= bits - 1)
                out[n++] = (uint32_t)(k * 64 + (size_t)vwi_ctz64(bits));
            w->dirty[k] = bits; /* what did not fit stays dirty */
            if (!bits)
                w->dirty_any[j] &= ~(1ull << (k & 63));
        }
    w->dirty_count -= n;
    return n;
}

void vw_world_clear_dirty(vw_world *w)
{
    if (!w)
        return;
    const size_t words = ((size_t)w->chunk_count + 63) / 64;
    memset(w->dirty, 0, words * sizeof *w->dirty);
    memset(w->dirty_any, 0, (words + 63) / 64 * sizeof *w->dirty_any);
    w->dirty_count = 0;
}
