/* mesher.c — greedy meshing of one chunk into axis-aligned quads.
 *
 * Greedy meshing after Mikola Lysenko, "Meshing in a Minecraft Game" (0fps.net, 2012): per
 * (axis, side, material), sweep each slice and grow a rectangle first along its row as far
 * as the face mask allows, then row by row while the whole run is still present, and clear
 * what it covers. We run it on bit masks (one machine word per row, as in the "binary greedy
 * mesher" variants of that idea), so growing a run and testing a whole row are a few
 * instructions.
 *
 * Face rule: a solid voxel a gets a face towards its neighbour b unless b hides it, that is
 * unless b is opaque or b == a (see-through next to the same see-through material). Air and
 * anything outside the world hide nothing.
 *
 * Steps, all on the caller's stack (no allocation unless mesh needs to grow):
 *   1. copy the chunk into a (C+2)^3 byte box with a one-voxel rim taken from the six face
 *      neighbours (the edges and corners of the box are never needed: faces look along axes);
 *   2. per padded row, two bit masks: where the voxel is air and where it is see-through; a
 *      row's faces towards a direction are then a few word operations (solid here, air or
 *      see-through there), and only rows that face a see-through neighbour compare bytes
 *      (b == a hides the face) 16 at a time (SSE2, with a scalar fallback);
 *   3. per material that has faces, and per direction, AND with the material's row mask and
 *      greedy-merge slice by slice. X faces need their (y, z) slices, so those masks are
 *      transposed first. Only the rows with a face ("lit") are visited, and only the rows
 *      and slices that hold faces are merged.
 * The steps are inlined into one function per chunk edge, whose loops then have constant
 * lengths (alone, gen:default meshed in 115 ms instead of 138; docs/performance.md). */
#include <stdlib.h>
#include <string.h>

#include "vw_internal.h"

#if defined(__SSE2__) && !defined(VW_MESHER_SCALAR)
#include <emmintrin.h>
#define VW_MESHER_SSE2 1
#endif

#define MAXC 32

/* The steps below are inlined into mesh_16 and mesh_32, so that the chunk edge is a constant
 * in each: loops of known length, rows copied without a call. */
#if defined(__GNUC__)
#define VW_SPECIALISE inline __attribute__((always_inline))
#define VW_NOINLINE __attribute__((noinline))
#else
#define VW_SPECIALISE inline
#define VW_NOINLINE
#endif
#define MAX_CLEAR 8        /* see-through materials compared directly in the row test         */

/* Scratch, on the caller's stack: sized per chunk edge (see mesh_16 / mesh_32 below), so a
 * 16-voxel chunk needs about 27 KiB of stack and a 32-voxel one about 135 KiB. */
#define SCRATCH_BYTES(c)                                                                                    \
    (2u * ((c) + 2) * ((c) + 2) * ((c) + 2) + 10u * (c) * (c) * sizeof(uint32_t) +                          \
     2u * ((c) + 2) * ((c) + 2) * sizeof(uint64_t))

typedef struct mesher {
    int32_t c, w;          /* chunk edge; padded edge C + 2                                  */
    int32_t base[3];       /* chunk minimum, voxels relative to the origin                   */
    uint8_t *mat;          /* (C+2)^3 materials, x fastest, with a one-voxel rim             */
    uint8_t *opq;          /* (C+2)^3: 0xFF where the material is opaque                     */
    uint32_t *face[6];     /* direction -> row (z*C + y) -> bit x: C*C words each            */
    uint32_t *lit;         /* the rows (z*C + y) with a face in any direction, ascending     */
    int32_t n_lit;
    uint32_t *matmask;     /* per lit row: the voxels of one material                        */
    uint32_t *sel;         /* per row: one material's faces in one direction; 0 if not lit  */
    uint32_t *rows;        /* the slices being merged; all 0 between two merges              */
    uint64_t *air, *glass; /* padded row (z*W + y) -> bit x + 1: air / see-through, not air  */
    uint8_t opaque[256];   /* 0xFF for materials that hide what is behind them               */
    uint8_t clear[MAX_CLEAR]; /* the see-through materials, when there are few               */
    int n_clear;           /* how many; MAX_CLEAR + 1 means "many: use the opq box"         */
} mesher;

static VW_SPECIALISE void mesher_init(mesher *m, int32_t c, void *scratch)
{
    const size_t box = (size_t)(c + 2) * (size_t)(c + 2) * (size_t)(c + 2), plane = (size_t)c * (size_t)c;
    m->c = c;
    m->w = c + 2;
    /* The word arrays first, so they are aligned as the scratch is. */
    uint32_t *words = scratch;
    for (int d = 0; d < 6; d++)
        m->face[d] = words + (size_t)d * plane;
    m->lit = words + 6 * plane;
    m->matmask = words + 7 * plane;
    m->sel = words + 8 * plane;
    m->rows = words + 9 * plane;
    m->air = (uint64_t *)(words + 10 * plane); /* 10 * C * C words: 8-byte aligned */
    m->glass = m->air + (size_t)m->w * (size_t)m->w;
    m->mat = (uint8_t *)(m->glass + (size_t)m->w * (size_t)m->w);
    m->opq = m->mat + box;
}

void vw_mesh_free(vw_mesh *mesh)
{
    if (!mesh)
        return;
    free(mesh->quads);
    mesh->quads = NULL;
    mesh->count = mesh->capacity = 0;
}

static int mesh_reserve_one(vw_mesh *mesh)
{
    if (mesh->count < mesh->capacity)
        return 1;
    size_t cap = mesh->capacity ? mesh->capacity * 2 : 256;
    vw_quad *q = realloc(mesh->quads, cap * sizeof *q);
    if (!q)
        return 0;
    mesh->quads = q;
    mesh->capacity = cap;
    return 1;
}

/* ---- step 1: the padded copy --------------------------------------------------------- */

static const vwi_chunk *neighbour(const vw_world *w, const int32_t cc[3], int axis, int dir)
{
    int32_t n[3] = {cc[0], cc[1], cc[2]};
    n[axis] += dir;
    if (n[axis] < 0 || n[axis] >= w->chunks[axis])
        return NULL;
    return &w->chunk[vwi_index(w, n[0], n[1], n[2])];
}

/* Copies the neighbour's layer that touches our face (axis, dir) into the rim. Rows along X
 * are contiguous in both boxes, so the Y and Z rims copy whole rows; the X rims gather. */
static VW_SPECIALISE void copy_rim(mesher *m, const vwi_chunk *nb, int axis, int dir)
{
    const int32_t c = m->c, pw = m->w;
    const int32_t rim = dir < 0 ? 0 : c + 1;  /* padded coordinate of the rim layer       */
    const int32_t src = dir < 0 ? c - 1 : 0;  /* the neighbour's layer that touches us      */
    const uint8_t *v = nb ? nb->voxels : NULL;
    const uint8_t fill = nb ? nb->uniform : 0; /* outside the world: empty                 */
    for (int32_t j = 0; j < c; j++) {
        if (axis == 0) {
            /* j = z; gather the column x = src of each row y */
            uint8_t *dst = &m->mat[rim + pw * (1 + pw * (j + 1))];
            for (int32_t i = 0; i < c; i++)
                dst[pw * i] = v ? v[src + c * (i + c * j)] : fill;
        } else {
            /* axis Y: j = z, the row (y = src, z = j); axis Z: j = y, the row (y = j, z = src) */
            const int32_t py = axis == 1 ? rim : j + 1, pz = axis == 1 ? j + 1 : rim;
            const int32_t sy = axis == 1 ? src : j, sz = axis == 1 ? j : src;
            uint8_t *dst = &m->mat[1 + pw * (py + pw * pz)];
            if (v)
                memcpy(dst, v + c * (sy + c * sz), (size_t)c);
            else
                memset(dst, fill, (size_t)c);
        }
    }
}

static VW_SPECIALISE void fill_padded(mesher *m, const vw_world *w, const vwi_chunk *ch, const int32_t cc[3])
{
    const int32_t c = m->c, pw = m->w;
    /* What does not hide a face: air and the see-through materials. With a few see-through
     * materials in the world (water, glass), the row test compares against each of them;
     * with many, one table lookup per byte builds an "opaque" box instead. */
    m->n_clear = 0;
    for (int i = 1; i < 256; i++) {
        const int see = (w->material[i].flags & VW_MAT_SEE_THROUGH) != 0;
        m->opaque[i] = see ? 0 : 0xFF;
        if (see && m->n_clear < MAX_CLEAR)
            m->clear[m->n_clear] = (uint8_t)i;
        if (see && m->n_clear <= MAX_CLEAR)
            m->n_clear++;
    }
    m->opaque[0] = 0;
    const int by_table = m->n_clear > MAX_CLEAR;
    if (by_table) /* the box's edges and corners are never written below, but read here */
        memset(m->mat, 0, (size_t)pw * (size_t)pw * (size_t)pw);

    for (int32_t z = 0; z < c; z++)
        for (int32_t y = 0; y < c; y++) {
            uint8_t *dst = &m->mat[1 + pw * ((y + 1) + pw * (z + 1))];
            if (ch->voxels)
                memcpy(dst, ch->voxels + c * (y + c * z), (size_t)c);
            else
                memset(dst, ch->uniform, (size_t)c);
        }
    for (int axis = 0; axis < 3; axis++)
        for (int dir = -1; dir <= 1; dir += 2)
            copy_rim(m, neighbour(w, cc, axis, dir), axis, dir);

    if (by_table) {
        const int32_t n = pw * pw * pw;
        for (int32_t i = 0; i < n; i++)
            m->opq[i] = m->opaque[m->mat[i]];
    }
}

/* ---- step 2: face masks -------------------------------------------------------------- */

#ifdef VW_MESHER_SSE2
/* row_bits for the 16 bytes of padded row r from p on, ORed into *air and *glass. */
static VW_SPECIALISE void row_bits_16(const mesher *m, int32_t r, int32_t p, uint64_t *air, uint64_t *glass)
{
    const __m128i zero = _mm_setzero_si128();
    const __m128i v = _mm_loadu_si128((const __m128i *)&m->mat[r + p]);
    const __m128i is_air = _mm_cmpeq_epi8(v, zero);
    __m128i clear;
    if (m->n_clear > MAX_CLEAR) {
        clear = _mm_cmpeq_epi8(_mm_loadu_si128((const __m128i *)&m->opq[r + p]), zero);
    } else {
        clear = is_air;
        for (int k = 0; k < m->n_clear; k++)
            clear = _mm_or_si128(clear, _mm_cmpeq_epi8(v, _mm_set1_epi8((char)m->clear[k])));
    }
    *air |= (uint64_t)(uint32_t)_mm_movemask_epi8(is_air) << p;
    *glass |= (uint64_t)(uint32_t)_mm_movemask_epi8(_mm_andnot_si128(is_air, clear)) << p;
}
#endif

/* Bits p of padded row (py, pz) for p in [lo, hi): where the voxel is air, and where it is
 * see-through but not air (it hides nothing, except a face of its own material). */
static VW_SPECIALISE void row_bits(const mesher *m, int32_t py, int32_t pz, int32_t lo, int32_t hi)
{
    const int32_t pw = m->w, r = pw * (py + pw * pz);
    uint64_t air = 0, glass = 0;
    int32_t p = lo;
#ifdef VW_MESHER_SSE2
    for (; p + 16 <= hi; p += 16)
        row_bits_16(m, r, p, &air, &glass);
    /* The rest as one more block that ends at hi: the bytes it reads twice give equal bits. */
    if (p < hi && hi - lo >= 16) {
        row_bits_16(m, r, hi - 16, &air, &glass);
        p = hi;
    }
#endif
    for (; p < hi; p++) {
        const uint8_t v = m->mat[r + p];
        air |= (uint64_t)(v == 0) << p;
        glass |= (uint64_t)(v != 0 && !m->opaque[v]) << p;
    }
    m->air[pz * pw + py] = air;
    m->glass[pz * pw + py] = glass;
}

/* Bit x set where byte a[x] == b[x], x in [0, C). */
static VW_SPECIALISE uint32_t equal_bits(const uint8_t *a, const uint8_t *b, int32_t c)
{
    uint32_t eq = 0;
#ifdef VW_MESHER_SSE2
    for (int32_t x = 0; x < c; x += 16)
        eq |= (uint32_t)_mm_movemask_epi8(_mm_cmpeq_epi8(_mm_loadu_si128((const __m128i *)&a[x]),
                                                         _mm_loadu_si128((const __m128i *)&b[x])))
              << x;
#else
    for (int32_t x = 0; x < c; x++)
        eq |= (uint32_t)(a[x] == b[x]) << x;
#endif
    return eq;
}

/* The faces of a row of solid voxels `solid` towards neighbours that are `air` or see-through
 * (`glass`), padded bits; `a` and `b` are the two rows' bytes at x = 0 (b: the neighbours). */
static VW_SPECIALISE uint32_t row_faces(uint64_t solid, uint64_t air, uint64_t glass, const uint8_t *a, const uint8_t *b,
                                 int32_t c)
{
    uint64_t f = solid & air;
    const uint64_t g = solid & glass;
    if (g) /* see-through neighbours: a face only where the materials differ */
        f |= g & ~((uint64_t)equal_bits(a, b, c) << 1);
    return (uint32_t)(f >> 1);
}

/* Direction order: -X, +X, -Y, +Y, -Z, +Z (direction d: axis d/2, side +1 when d is odd).
 * A solid voxel a has a face towards b where b is air, or see-through and b != a. */
static VW_SPECIALISE void face_masks(mesher *m)
{
    const int32_t c = m->c, pw = m->w, pp = pw * pw;
    const uint64_t inner = ((1ull << c) - 1) << 1; /* padded bits of x = 0 .. C-1 */
    /* The rows a face can look into: the interior rows with their X rims, the rim rows
     * inside them (the box's edges are never read). */
    for (int32_t z = 1; z <= c; z++)
        for (int32_t y = 1; y <= c; y++)
            row_bits(m, y, z, 0, c + 2);
    for (int32_t i = 1; i <= c; i++) {
        row_bits(m, 0, i, 1, c + 1);
        row_bits(m, c + 1, i, 1, c + 1);
        row_bits(m, i, 0, 1, c + 1);
        row_bits(m, i, c + 1, 1, c + 1);
    }
    const uint64_t *air = m->air, *glass = m->glass;
    for (int32_t z = 1; z <= c; z++)
        for (int32_t y = 1; y <= c; y++) {
            const int32_t r = z * pw + y, o = (z - 1) * c + (y - 1);
            const uint8_t *a = &m->mat[pw * r + 1];
            const uint64_t solid = ~air[r] & inner;
            m->face[0][o] = row_faces(solid, air[r] << 1, glass[r] << 1, a, a - 1, c); /* x - 1 */
            m->face[1][o] = row_faces(solid, air[r] >> 1, glass[r] >> 1, a, a + 1, c);
            m->face[2][o] = row_faces(solid, air[r - 1], glass[r - 1], a, a - pw, c);
            m->face[3][o] = row_faces(solid, air[r + 1], glass[r + 1], a, a + pw, c);
            m->face[4][o] = row_faces(solid, air[r - pw], glass[r - pw], a, a - pp, c);
            m->face[5][o] = row_faces(solid, air[r + pw], glass[r + pw], a, a + pp, c);
        }
}

/* ---- step 3: greedy merge ------------------------------------------------------------ */

/* Greedy-merges slices of C rows (slice s: rows[s*C + r], bit c of a row = column c) and
 * emits one quad per rectangle; filled[s] has bit r set where row r of slice s has bits, so
 * empty slices and rows are never visited. `map` says which quad fields the slice, row and
 * column index (the u/v assignment at the end of the loop). */
typedef struct slice_map {
    int axis, side;
    int row_is_u;        /* rows run along u (columns along v), or the other way round   */
} slice_map;

static VW_SPECIALISE int merge_slices(mesher *m, const vw_world *w, uint8_t material, const slice_map *map,
                                      uint32_t *all_rows, const uint32_t *filled, vw_mesh *mesh)
{
    const int32_t c = m->c;
    const int ua = (map->axis + 1) % 3, va = (map->axis + 2) % 3;
    const uint8_t flags = (uint8_t)w->material[material].flags;
    for (int32_t s = 0; s < c; s++) {
        uint32_t *rows = &all_rows[s * c];
        for (uint32_t todo = filled[s]; todo; todo &= todo - 1) {
            const int32_t r = vwi_ctz64(todo);
            while (rows[r]) { /* rows merged into one above may have been emptied */
                const uint32_t bits = rows[r];
                const int c0 = vwi_ctz64(bits);
                const int width = vwi_ctz64(~(uint64_t)(bits >> c0));
                const uint32_t run = (uint32_t)(((1ull << width) - 1) << c0);
                int32_t r1 = r + 1;
                while (r1 < c && (rows[r1] & run) == run)
                    rows[r1++] &= ~run;
                rows[r] &= ~run;
                if (!mesh_reserve_one(mesh))
                    return 0;
                vw_quad *q = &mesh->quads[mesh->count++];
                q->axis = (uint8_t)map->axis;
                q->side = (int8_t)map->side;
                q->material = material;
                q->flags = flags;
                q->plane = m->base[map->axis] + s + (map->side > 0);
                int32_t r0 = r, cb = c0, ce = c0 + width;
                if (map->row_is_u) {
                    q->u0 = m->base[ua] + r0;
                    q->u1 = m->base[ua] + r1;
                    q->v0 = m->base[va] + cb;
                    q->v1 = m->base[va] + ce;
                } else {
                    q->u0 = m->base[ua] + cb;
                    q->u1 = m->base[ua] + ce;
                    q->v0 = m->base[va] + r0;
                    q->v1 = m->base[va] + r1;
                }
            }
        }
    }
    return 1;
}

/* Lays out one direction's selected masks (sel[z*C + y], bit x; only lit rows have bits) as
 * slices for merge_slices, and merges them. Returns 0 on out of memory. */
static VW_SPECIALISE int merge_direction(mesher *m, const vw_world *w, uint8_t material, int d, vw_mesh *mesh)
{
    const int32_t c = m->c;
    const int axis = d / 2;
    slice_map map = {axis, (d & 1) ? 1 : -1, 0};
    uint32_t filled[MAXC] = {0}; /* slice s -> bit r: row r has faces */
    uint32_t *rows = m->rows;    /* all 0: the last merge consumed every bit it was given */
    if (axis == 0) {
        /* Slice x: rows z, columns y (u = Y along columns, v = Z along rows). */
        for (int32_t k = 0; k < m->n_lit; k++) {
            const int32_t i = (int32_t)m->lit[k], z = i / c, y = i % c;
            for (uint32_t b = m->sel[i]; b; b &= b - 1) {
                const int32_t x = vwi_ctz64(b);
                rows[x * c + z] |= 1u << y;
                filled[x] |= 1u << z;
            }
        }
    } else if (axis == 1) {
        /* Slice y: rows z (u = Z), columns x (v = X). */
        for (int32_t k = 0; k < m->n_lit; k++) {
            const int32_t i = (int32_t)m->lit[k], z = i / c, y = i % c;
            filled[y] |= (uint32_t)((rows[y * c + z] = m->sel[i]) != 0) << z;
        }
        map.row_is_u = 1;
    } else {
        /* Slice z: rows y (v = Y), columns x (u = X): sel is already in that order, and the
         * merge leaves it all 0 as it leaves rows. */
        rows = m->sel;
        for (int32_t k = 0; k < m->n_lit; k++) {
            const int32_t i = (int32_t)m->lit[k];
            filled[i / c] |= (uint32_t)(rows[i] != 0) << (i % c);
        }
    }
    return merge_slices(m, w, material, &map, rows, filled, mesh);
}

/* The chunk's voxels of row i = z*C + y (x = 0 .. C-1) in the padded box. */
static VW_SPECIALISE const uint8_t *voxel_row(const mesher *m, int32_t i)
{
    return &m->mat[1 + m->w * ((i % m->c + 1) + m->w * (i / m->c + 1))];
}

/* Bit x set where row[x] == v, x in [0, C). */
static VW_SPECIALISE uint32_t same_bits(const uint8_t *row, uint8_t v, int32_t c)
{
    uint32_t bits = 0;
#ifdef VW_MESHER_SSE2
    const __m128i key = _mm_set1_epi8((char)v);
    for (int32_t x = 0; x < c; x += 16)
        bits |= (uint32_t)_mm_movemask_epi8(_mm_cmpeq_epi8(_mm_loadu_si128((const __m128i *)&row[x]), key)) << x;
#else
    for (int32_t x = 0; x < c; x++)
        bits |= (uint32_t)(row[x] == v) << x;
#endif
    return bits;
}

/* 1 when a uniform solid chunk is hidden on all six sides (the bulk of rock and of deep
 * water), so that meshing it costs nothing. */
static int buried(const vw_world *w, const vwi_chunk *ch, const int32_t cc[3])
{
    const uint8_t a = ch->uniform;
    for (int axis = 0; axis < 3; axis++)
        for (int dir = -1; dir <= 1; dir += 2) {
            const vwi_chunk *nb = neighbour(w, cc, axis, dir);
            if (!nb || nb->voxels || !nb->uniform)
                return 0;
            if (nb->uniform != a && (w->material[nb->uniform].flags & VW_MAT_SEE_THROUGH))
                return 0;
        }
    return 1;
}

/* Merges the faces of material v in every direction that has faces (dir_any); `only` when
 * no other material has faces. Returns 0 on out of memory. */
static VW_SPECIALISE int mesh_material(mesher *m, const vw_world *w, uint8_t v, int only, const uint32_t dir_any[6],
                                       vw_mesh *mesh)
{
    uint32_t *matmask = m->matmask;
    for (int32_t k = 0; k < m->n_lit; k++) {
        const uint32_t i = m->lit[k];
        matmask[i] = only ? ~0u : same_bits(voxel_row(m, (int32_t)i), v, m->c);
    }
    for (int d = 0; d < 6; d++) {
        if (!dir_any[d])
            continue;
        uint32_t some = 0;
        for (int32_t k = 0; k < m->n_lit; k++) {
            const uint32_t i = m->lit[k];
            some |= m->sel[i] = m->face[d][i] & matmask[i];
        }
        if (some && !merge_direction(m, w, v, d, mesh)) /* most materials face few directions */
            return 0;
    }
    return 1;
}

/* Meshes a chunk that has solid voxels and may have faces, with scratch `m`. */
static VW_SPECIALISE vw_status mesh_run(mesher *m, const vw_world *w, const vwi_chunk *ch, const int32_t cc[3], vw_mesh *mesh)
{
    const int32_t c = m->c;
    for (int a = 0; a < 3; a++)
        m->base[a] = cc[a] * c;
    fill_padded(m, w, ch, cc);
    face_masks(m);

    /* The rows with faces, and the materials that have at least one: per row, one byte
     * compare finds every voxel of the material of its first unmarked face. */
    uint64_t present[4] = {0, 0, 0, 0};
    uint32_t dir_any[6] = {0, 0, 0, 0, 0, 0};
    int kinds = 0;
    m->n_lit = 0;
    for (int32_t i = 0; i < c * c; i++) {
        uint32_t u = 0;
        for (int d = 0; d < 6; d++) {
            dir_any[d] |= m->face[d][i];
            u |= m->face[d][i];
        }
        if (!u)
            continue;
        m->lit[m->n_lit++] = (uint32_t)i;
        const uint8_t *row = voxel_row(m, i);
        while (u) {
            const uint8_t v = row[vwi_ctz64(u)];
            u &= ~same_bits(row, v, c);
            if (!(present[v >> 6] & (1ull << (v & 63)))) {
                present[v >> 6] |= 1ull << (v & 63);
                kinds++;
            }
        }
    }

    /* merge_direction's invariants: rows all 0, sel 0 outside the lit rows. */
    memset(m->rows, 0, sizeof(uint32_t) * (size_t)(c * c));
    memset(m->sel, 0, sizeof(uint32_t) * (size_t)(c * c));
    for (int word = 0; word < 4; word++)
        for (uint64_t bits = present[word]; bits; bits &= bits - 1)
            if (!mesh_material(m, w, (uint8_t)(word * 64 + vwi_ctz64(bits)), kinds == 1, dir_any, mesh))
                return VW_ERROR_OUT_OF_MEMORY;
    return VW_OK;
}

/* One frame per chunk edge, so that 16-voxel chunks do not pay the stack of 32-voxel ones. */

static VW_NOINLINE vw_status mesh_16(const vw_world *w, const vwi_chunk *ch, const int32_t cc[3], vw_mesh *mesh)
{
    _Alignas(16) uint8_t scratch[SCRATCH_BYTES(16)];
    mesher m;
    mesher_init(&m, 16, scratch);
    return mesh_run(&m, w, ch, cc, mesh);
}

static VW_NOINLINE vw_status mesh_32(const vw_world *w, const vwi_chunk *ch, const int32_t cc[3], vw_mesh *mesh)
{
    _Alignas(16) uint8_t scratch[SCRATCH_BYTES(32)];
    mesher m;
    mesher_init(&m, 32, scratch);
    return mesh_run(&m, w, ch, cc, mesh);
}

vw_status vw_mesh_chunk(const vw_world *w, uint32_t index, vw_mesh *mesh)
{
    if (!w || !mesh || index >= w->chunk_count)
        return VW_ERROR_INVALID_ARGUMENT;
    mesh->count = 0;
    const vwi_chunk *ch = &w->chunk[index];
    if (ch->solid == 0)
        return VW_OK;
    int32_t cc[3];
    vw_world_chunk_coords(w, index, cc);
    if (!ch->voxels && buried(w, ch, cc))
        return VW_OK;
    return w->chunk_size == 16 ? mesh_16(w, ch, cc, mesh) : mesh_32(w, ch, cc, mesh);
}
