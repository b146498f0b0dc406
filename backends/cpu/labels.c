/* labels.c — see labels.h; the walk that reads the blocks is trace_core.h's vis_label_walk.
 *
 * A leaf's labels, bit-parallel: the squares its quads cover go into rows along x (leaf_planes:
 * per y and z a bit for each x-plane 0..16; per y-plane and z, and per z-plane and y, a bit for
 * each x).
 * The labels of the x = 0 column come from the y and z planes crossed from the corner, every
 * row's from the prefix parity of its x-planes (a shift-XOR ladder), and the y and z planes
 * are then checked row against row: a leaf where some plane's squares disagree with the
 * labels on its two sides has no two-labelling and keeps the plane walk. Planes 0 and 16 are
 * the leaf's boundary, which the walk visits exactly (its crossings leave the leaf). */
#include <string.h>

#include "cpu/labels.h"

/* Bits lo..hi of 0..15, clamped; 0 when empty. */
static uint16_t span(int lo, int hi)
{
    if (lo < 0)
        lo = 0;
    if (hi > 15)
        hi = 15;
    if (hi < lo)
        return 0;
    return (uint16_t)(((2u << hi) - 1u) & ~((1u << lo) - 1u));
}

static int min16(int v) { return v < 16 ? v : 16; }
static int max0(int v) { return v > 0 ? v : 0; }

/* The loud voxels of a quad with no area (u1 <= u0 or v1 <= v0): the conservative quad test
 * may still take it, and it covers no square from which the loud bits below would follow. */
static void mark_thin(int a, int k, int u0, int v0, int u1, int v1, uint16_t loud[16][16])
{
    if (a == 0) { /* u = y, v = z */
        for (int y = max0(u0 - 1); y <= u1 && y < 16; ++y)
            for (int z = max0(v0 - 1); z <= v1 && z < 16; ++z)
                loud[y][z] |= span(k - 1, k);
    } else if (a == 1) { /* u = z, v = x */
        for (int y = max0(k - 1); y <= k && y < 16; ++y)
            for (int z = max0(u0 - 1); z <= u1 && z < 16; ++z)
                loud[y][z] |= span(v0 - 1, v1);
    } else { /* u = x, v = y */
        for (int z = max0(k - 1); z <= k && z < 16; ++z)
            for (int y = max0(v0 - 1); y <= v1 && y < 16; ++y)
                loud[y][z] |= span(u0 - 1, u1);
    }
}

/* Row r dilated by one along x. */
static uint16_t grow_x(uint32_t r) { return (uint16_t)(r | r << 1 | r >> 1); }

/* A leaf's planes as rows along x, each array with a zero border where it is read one past
 * its edge, so that the loops below have no branches (the compiler vectorises them):
 *  - X[1 + y][1 + z]: bit k, the x-plane k (0..16) covers square (y, z);
 *  - Y[k][1 + z]: bit x, the y-plane k covers square (x, z);
 *  - Zt[1 + y][k]: bit x, the z-plane k covers square (x, y) (transposed: rows of one y lie
 *    together, as the labels' rows do). */
typedef struct leaf_planes {
    uint32_t X[18][18];
    uint16_t Y[17][18];
    uint16_t Zt[18][17];
} leaf_planes;

/* The covered squares of every plane, and the loud voxels as rows along x (loud[y][z], bit
 * x): those on either side of a covered square or of a square beside it (its edges and
 * corners, where the walk's slack may take the quad). */
static void cover_rows(const vis_flat_leaf *lf, const uint32_t *buckets, const uint32_t *quads, leaf_planes *P,
                       uint16_t loud[16][16])
{
    memset(P, 0, sizeof *P);
    memset(loud, 0, 16 * 16 * sizeof(uint16_t));
    const uint32_t *bk = buckets + lf->bucket_offset;
    const uint32_t *packed = quads + lf->quad_offset;
    for (int a = 0; a < 3; ++a)
        for (int k = 0; k <= 16; ++k)
            for (uint32_t q = bk[17 * a + k]; q < bk[17 * a + k + 1]; ++q) {
                uint32_t w = packed[q];
                int u0 = (int)VIS_PQ_FIELD(w, 0u), v0 = (int)VIS_PQ_FIELD(w, 1u);
                int u1 = (int)VIS_PQ_FIELD(w, 2u), v1 = (int)VIS_PQ_FIELD(w, 3u);
                if (u1 <= u0 || v1 <= v0)
                    mark_thin(a, k, u0, v0, u1, v1, loud);
                else if (a == 0) /* u = y, v = z */
                    for (int y = u0; y < min16(u1); ++y)
                        for (int z = v0; z < min16(v1); ++z)
                            P->X[1 + y][1 + z] |= 1u << k;
                else if (a == 1) /* u = z, v = x */
                    for (int z = u0; z < min16(u1); ++z)
                        P->Y[k][1 + z] |= span(v0, v1 - 1);
                else /* u = x, v = y */
                    for (int y = v0; y < min16(v1); ++y)
                        P->Zt[1 + y][k] |= span(u0, u1 - 1);
            }
    /* x-planes: voxel x touches planes x and x + 1; one square more along z, then y. */
    uint16_t e[18][16];
    for (int y = 0; y < 18; ++y)
        for (int z = 0; z < 16; ++z) {
            uint32_t r = P->X[y][z] | P->X[y][z + 1] | P->X[y][z + 2];
            e[y][z] = (uint16_t)(r | r >> 1);
        }
    for (int y = 0; y < 16; ++y)
        for (int z = 0; z < 16; ++z)
            loud[y][z] |= (uint16_t)(e[y][z] | e[y + 1][z] | e[y + 2][z]);
    /* y-planes: voxel y touches planes y and y + 1; one square more along x and z. */
    uint16_t g[17][16];
    for (int k = 0; k < 17; ++k)
        for (int z = 0; z < 16; ++z)
            g[k][z] = grow_x((uint32_t)P->Y[k][z] | P->Y[k][z + 1] | P->Y[k][z + 2]);
    for (int y = 0; y < 16; ++y)
        for (int z = 0; z < 16; ++z)
            loud[y][z] |= (uint16_t)(g[y][z] | g[y + 1][z]);
    /* z-planes: voxel z touches planes z and z + 1; one square more along x and y. */
    for (int y = 0; y < 16; ++y) {
        uint16_t h[17];
        for (int k = 0; k < 17; ++k)
            h[k] = grow_x((uint32_t)P->Zt[y][k] | P->Zt[y + 1][k] | P->Zt[y + 2][k]);
        for (int z = 0; z < 16; ++z)
            loud[y][z] |= (uint16_t)(h[z] | h[z + 1]);
    }
}

/* Two labels as rows along x ([y][z]); 0 when the planes admit none. */
static int label_rows(const leaf_planes *P, uint16_t lab[16][16])
{
    uint16_t c0[16][16]; /* all ones where voxel (0, y, z) has label 1 */
    c0[0][0] = 0;
    for (int z = 1; z < 16; ++z)
        c0[0][z] = (uint16_t)(c0[0][z - 1] ^ (0u - (P->Zt[1][z] & 1u)));
    for (int y = 1; y < 16; ++y)
        for (int z = 0; z < 16; ++z)
            c0[y][z] = (uint16_t)(c0[y - 1][z] ^ (0u - (P->Y[y][1 + z] & 1u)));
    for (int y = 0; y < 16; ++y)
        for (int z = 0; z < 16; ++z) {
            uint32_t p = P->X[1 + y][1 + z] & 0xFFFEu; /* interior planes 1..15 */
            p ^= p << 1;
            p ^= p << 2;
            p ^= p << 4;
            p ^= p << 8;
            lab[y][z] = (uint16_t)(p ^ c0[y][z]);
        }
    /* Every interior y- and z-plane's squares must be where the labels on its sides differ. */
    uint16_t bad = 0;
    for (int y = 1; y < 16; ++y)
        for (int z = 0; z < 16; ++z)
            bad |= (uint16_t)(lab[y - 1][z] ^ lab[y][z] ^ P->Y[y][1 + z]);
    for (int y = 0; y < 16; ++y)
        for (int z = 1; z < 16; ++z)
            bad |= (uint16_t)(lab[y][z - 1] ^ lab[y][z] ^ P->Zt[1 + y][z]);
    return bad == 0;
}

/* Rows along x ([y][z]) as 4^3 bricks: row (y, z)'s nibble x/4 goes to brick x/4 + 4 (y/4) +
 * 16 (z/4), at bit 4 (y%4) + 16 (z%4). The four rows z = 4 zb .. 4 zb + 3 of one y, as the
 * 16-bit lanes of a word, hold a 4x4 matrix of nibbles per lane (nibble x/4 at bits 4 (x/4));
 * the four such words of y = 4 yb .. 4 yb + 3 hold, lane by lane, a 4x4 matrix [y%4][x/4] of
 * nibbles, and each brick wants its transpose [x/4][y%4]: two rounds of swaps (of byte pairs,
 * then of nibbles) give all four bricks of that yb and zb at once. */
static void to_bricks(const uint16_t rows[16][16], uint64_t out[64])
{
    for (uint32_t yb = 0; yb < 4u; ++yb)
        for (uint32_t zb = 0; zb < 4u; ++zb) {
            uint64_t a[4];
            for (uint32_t k = 0; k < 4u; ++k) {
                const uint16_t *r = &rows[4u * yb + k][4u * zb];
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
                memcpy(&a[k], r, sizeof a[k]); /* the same word, in one load */
#else
                a[k] = (uint64_t)r[0] | (uint64_t)r[1] << 16 | (uint64_t)r[2] << 32 | (uint64_t)r[3] << 48;
#endif
            }
            for (uint32_t k = 0; k < 2u; ++k) { /* the upper byte of a[k] with the lower of a[k + 2] */
                uint64_t t = ((a[k] >> 8) ^ a[k + 2]) & 0x00FF00FF00FF00FFull;
                a[k + 2] ^= t;
                a[k] ^= t << 8;
            }
            for (uint32_t k = 0; k < 4u; k += 2u) { /* nibbles 1, 3 of a[k] with 0, 2 of a[k + 1] */
                uint64_t t = ((a[k] >> 4) ^ a[k + 1]) & 0x0F0F0F0F0F0F0F0Full;
                a[k + 1] ^= t;
                a[k] ^= t << 4;
            }
            memcpy(&out[4u * yb + 16u * zb], a, sizeof a); /* bricks x/4 = 0..3 */
        }
}

static void put64(uint32_t *p, uint64_t v)
{
    p[0] = (uint32_t)v;
    p[1] = (uint32_t)(v >> 32);
}

uint32_t vis_labels_build_leaf(const vis_flat_leaf *lf, const uint32_t *buckets, const uint32_t *quads, uint32_t *out)
{
    if (lf->quad_count == 0u || (lf->dims_xy & 0xFFFFu) != 16u || (lf->dims_xy >> 16) != 16u || lf->dims_z != 16u ||
        lf->loose_count || lf->tri_count || lf->quad_offset - lf->table_offset != 1u ||
        lf->bucket_offset == 0xFFFFFFFFu)
        return 0;
    const uint32_t *packed = quads + lf->quad_offset;
    for (uint32_t q = 0; q < lf->quad_count; ++q)
        if (VIS_PQ_FLAGS(packed[q]) || VIS_PQ_TABLE(packed[q]))
            return 0;
    leaf_planes P;
    uint16_t loud[16][16], lab[16][16];
    cover_rows(lf, buckets, quads, &P, loud);
    if (!label_rows(&P, lab))
        return 0;
    uint64_t lb[64], tb[64], L = 0, M = 0, U = 0;
    to_bricks(loud, lb);
    to_bricks(lab, tb);
    for (uint32_t j = 0; j < 64u; ++j) {
        if (!lb[j])
            continue;
        L |= 1ull << j;
        uint64_t on = tb[j] & lb[j]; /* the labels the walk reads: the loud voxels' */
        if (on == lb[j])
            U |= 1ull << j;
        else if (on)
            M |= 1ull << j;
    }
    uint32_t n = VIS_LW_HEADER;
    put64(out, L);
    put64(out + 2, M);
    put64(out + 4, U);
    for (uint32_t j = 0; j < 64u; ++j)
        if (L >> j & 1u) {
            put64(out + n, lb[j]);
            n += 2u;
        }
    for (uint32_t j = 0; j < 64u; ++j)
        if (M >> j & 1u) {
            put64(out + n, tb[j]);
            n += 2u;
        }
    return n;
}

void vis_labels_free(vis_labels *lab)
{
    vis_host_free(lab->alloc, lab->words);
    lab->words = NULL;
    lab->leaf_count = lab->labelled = 0;
    lab->used = lab->cap = lab->stale = 0;
    lab->failed = VIS_OK;
}

/* The most words the array can hold: offsets are 32-bit words, and its bytes must fit a size_t. */
#define MAX_WORDS ((size_t)UINT32_MAX < SIZE_MAX / sizeof(uint32_t) ? (size_t)UINT32_MAX : SIZE_MAX / sizeof(uint32_t))

/* The words the array may hold under max_bytes. */
static size_t words_within(uint64_t max_bytes)
{
    uint64_t w = max_bytes / sizeof(uint32_t);
    return w < (uint64_t)MAX_WORDS ? (size_t)w : MAX_WORDS;
}

/* Room for `more` words past `used`, within `limit` words: the array grows by an eighth, at
 * least (memory counts more than the copies: edits append a block now and then). */
static vis_status reserve(vis_labels *lab, size_t more, size_t limit)
{
    size_t want = lab->used + more;
    if (want > limit)
        return VIS_ERROR_BUDGET; /* even where the array has the room (a full build's reservation) */
    if (want <= lab->cap)
        return VIS_OK;
    size_t cap = lab->cap + lab->cap / 8u;
    cap = cap < want ? want : cap > limit ? limit : cap;
    uint32_t *w = vis_host_alloc(lab->alloc, cap * sizeof *w);
    if (!w)
        return VIS_ERROR_OUT_OF_MEMORY;
    if (lab->words)
        memcpy(w, lab->words, lab->used * sizeof *w);
    vis_host_free(lab->alloc, lab->words);
    lab->words = w;
    lab->cap = cap;
    return VIS_OK;
}

/* The words of leaf li's block now (0: none), from its header. */
static uint32_t block_words(const vis_labels *lab, uint32_t li)
{
    uint32_t at = lab->words[li];
    return at ? vis_labels_block_words(lab->words + at) : 0u;
}

/* Leaf li's block of n words appended to the array, within `limit` words. */
static vis_status append_block(vis_labels *lab, uint32_t li, const uint32_t *block, uint32_t n, size_t limit)
{
    vis_status st = reserve(lab, n, limit);
    if (st != VIS_OK)
        return st;
    memcpy(lab->words + lab->used, block, n * sizeof *block);
    lab->words[li] = (uint32_t)lab->used;
    lab->used += n;
    lab->labelled++;
    return VIS_OK;
}

static vis_status compact(vis_labels *lab, size_t limit);

/* Leaf li's block from the view: in place where it fits, else appended (after copying the
 * live blocks out, where the stale ones are what keeps it from the limit). */
static vis_status update_leaf(vis_labels *lab, const vis_scene_view *v, uint32_t li, size_t limit)
{
    uint32_t block[VIS_LABELS_MAX_BLOCK];
    uint32_t n = vis_labels_build_leaf(&v->leaves[li], v->buckets, v->quads, block);
    uint32_t old = block_words(lab, li);
    if (n && n <= old) {
        memcpy(lab->words + lab->words[li], block, n * sizeof *block);
        lab->stale += old - n;
        return VIS_OK;
    }
    lab->stale += old;
    lab->labelled -= old != 0;
    lab->words[li] = 0;
    if (!n)
        return VIS_OK;
    vis_status st = append_block(lab, li, block, n, limit);
    if (st == VIS_ERROR_BUDGET && lab->stale && compact(lab, limit) == VIS_OK)
        st = append_block(lab, li, block, n, limit); /* the stale blocks were what did not fit */
    return st;
}

/* A full build goes in batches of BATCH leaves: each built on the threads into its own
 * slot of the scratch, then appended in leaf order. */
#define BATCH 1024u

typedef struct batch_job {
    const vis_scene_view *v;
    uint32_t first, count;
    uint32_t *blocks; /* BATCH slots of VIS_LABELS_MAX_BLOCK words */
    uint32_t *words;  /* each slot's block size, 0: none          */
} batch_job;

static void build_one(uint32_t i, void *arg)
{
    batch_job *b = arg;
    const vis_scene_view *v = b->v;
    uint32_t li = b->first + i;
    b->words[i] = vis_labels_build_leaf(&v->leaves[li], v->buckets, v->quads, b->blocks + (size_t)i * VIS_LABELS_MAX_BLOCK);
}

/* Every leaf's block again, packed, in leaf order, while they stay within `limit` words (the
 * caller copies the array out to its size). */
static vis_status rebuild(vis_labels *lab, const vis_scene_view *v, size_t limit, vis_labels_run_fn run,
                          void *run_user)
{
    vis_labels_free(lab);
    if ((size_t)v->leaf_count + 1u > limit)
        return VIS_ERROR_BUDGET; /* not even the offsets: nothing to reserve */
    batch_job b = {v, 0, 0, NULL, NULL};
    /* Room for every block a leaf of quads can have, taken at once (the call's scratch, not
     * held to the limit): the pages the blocks do not reach are never touched, and the array
     * is copied to its size at the end (growing it block by block cost more in copies and
     * page faults than the blocks themselves). */
    uint64_t most = (uint64_t)v->leaf_count + 1u;
    for (uint32_t li = 0; li < v->leaf_count; ++li)
        most += v->leaves[li].quad_count ? VIS_LABELS_MAX_BLOCK : 0u;
    size_t bound = most < (uint64_t)MAX_WORDS ? (size_t)most : MAX_WORDS; /* the blocks stop at the limit, no more */
    b.blocks = vis_host_alloc(lab->alloc, (size_t)BATCH * (VIS_LABELS_MAX_BLOCK + 1u) * sizeof(uint32_t));
    vis_status st = b.blocks ? reserve(lab, bound, MAX_WORDS) : VIS_ERROR_OUT_OF_MEMORY;
    if (st != VIS_OK) {
        vis_host_free(lab->alloc, b.blocks);
        return st;
    }
    b.words = b.blocks + (size_t)BATCH * VIS_LABELS_MAX_BLOCK;
    memset(lab->words, 0, ((size_t)v->leaf_count + 1u) * sizeof *lab->words);
    lab->leaf_count = v->leaf_count;
    lab->used = (size_t)v->leaf_count + 1u; /* word leaf_count stays 0: no block starts at 0 */
    for (b.first = 0; st == VIS_OK && b.first < v->leaf_count; b.first += b.count) {
        b.count = v->leaf_count - b.first < BATCH ? v->leaf_count - b.first : BATCH;
        if (run)
            run(run_user, b.count, build_one, &b);
        else
            for (uint32_t i = 0; i < b.count; ++i)
                build_one(i, &b);
        for (uint32_t i = 0; st == VIS_OK && i < b.count; ++i)
            if (b.words[i])
                st = append_block(lab, b.first + i, b.blocks + (size_t)i * VIS_LABELS_MAX_BLOCK, b.words[i], limit);
    }
    vis_host_free(lab->alloc, b.blocks);
    return st;
}

/* The live blocks copied together, in leaf order, into a new array a sixteenth larger than
 * they need (no larger than `limit` words). VIS_ERROR_BUDGET when they need more than the
 * limit, VIS_ERROR_OUT_OF_MEMORY when the new array cannot be had: the array as it was. */
static vis_status compact(vis_labels *lab, size_t limit)
{
    size_t need = (size_t)lab->leaf_count + 1u;
    for (uint32_t li = 0; li < lab->leaf_count; ++li)
        need += block_words(lab, li);
    if (need > limit)
        return VIS_ERROR_BUDGET;
    size_t cap = need + need / 16u < limit ? need + need / 16u : limit;
    uint32_t *w = vis_host_alloc(lab->alloc, cap * sizeof *w);
    if (!w)
        return VIS_ERROR_OUT_OF_MEMORY;
    memset(w, 0, ((size_t)lab->leaf_count + 1u) * sizeof *w);
    size_t at = (size_t)lab->leaf_count + 1u;
    for (uint32_t li = 0; li < lab->leaf_count; ++li) {
        uint32_t n = block_words(lab, li);
        if (!n)
            continue;
        memcpy(w + at, lab->words + lab->words[li], n * sizeof *w);
        w[li] = (uint32_t)at;
        at += n;
    }
    vis_host_free(lab->alloc, lab->words);
    lab->words = w;
    lab->used = at;
    lab->cap = cap;
    lab->stale = 0;
    return VIS_OK;
}

vis_status vis_labels_sync(vis_labels *lab, const vis_scene_view *view, const vis_scene_changes *changes,
                           uint64_t max_bytes, vis_labels_run_fn run, void *run_user)
{
    size_t limit = words_within(max_bytes);
    int same_tree = lab->leaf_count == view->leaf_count;
    /* Without labels since a failure: a partial sync tries again only once the room has grown
     * by an eighth, so that a scene at its limit does not rebuild them at every edit. */
    int room_grew = max_bytes > lab->failed_room && max_bytes - lab->failed_room > lab->failed_room / 8u;
    if (lab->failed && !changes->full && same_tree && !room_grew)
        return lab->failed;
    vis_status st = VIS_OK;
    if (changes->full || !lab->words || !same_tree) {
        st = rebuild(lab, view, limit, run, run_user);
        if (st == VIS_OK) /* to what the blocks need (kept as it was if that memory cannot be had) */
            (void)compact(lab, limit);
    } else {
        for (uint32_t i = 0; st == VIS_OK && i < changes->leaf_count; ++i)
            st = update_leaf(lab, view, changes->leaves[i], limit);
        /* Stale blocks past an eighth of the array: copied out (if that memory cannot be had
         * now, the next sync tries again; the array is still correct). */
        if (st == VIS_OK && lab->stale > lab->used / 8u)
            (void)compact(lab, limit);
    }
    if (st == VIS_OK && lab->cap > limit) {
        /* The room shrank under the array (the scene grew), or the full build's reservation
         * could not be copied out: to its size (no more than the limit), or no labels. */
        st = compact(lab, limit);
    }
    if (st != VIS_OK) {
        vis_labels_free(lab);
        lab->leaf_count = view->leaf_count;
        lab->failed = st;
        lab->failed_room = max_bytes;
        return st;
    }
    return VIS_OK;
}
