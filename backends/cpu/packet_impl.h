/* packet_impl.h — a tile of primary rays traced as one packet. Included by packet_tile.c
 * (16x16 tiles) and packet_ray.c (one ray, where tiles spread too wide), each defining
 * PK_TILE_W, PK_TILE_H and PK_ENTRY, the name of the traced-tile function it exports.
 *
 * Every ray of a pinhole camera starts at the eye, so one front-to-back walk of the kd-tree
 * serves the whole tile (packet traversal: Wald, Slusallek, Benthin, Wagner 2001, "Interactive
 * rendering with coherent ray tracing"; the tile as a frustum: Reshetov, Soupikov, Hurley 2005,
 * "Multi-level ray tracing algorithm"). The tile's directions are bounded by intervals
 * (Boulos et al. 2007, "Packet-based Whitted and distribution ray tracing"), and with them:
 *  - a kd node is skipped when its subtree holds nothing (occupancy.h), when no ray of the
 *    tile can enter its box, or the part of its box where its primitives lie on y (its fill),
 *    or when every ray already has a hit nearer than the box;
 *  - a leaf is opened only for the units (4x2 blocks of lanes) whose rays can enter its
 *    content box (the box of its packed quads, vis_flat_leaf.content_box; the empty-space
 *    skip at the leaf's level of Lee & Han 2005, as in trace_core.h's per-ray leaf walk)
 *    before their own farthest hit, and its planes are walked only
 *    inside that box: axis by axis, the axis the rays move along most first, or, in a level
 *    view (y the axis they move along least), the planes of every axis whose rays all move one
 *    way in one sequence, by the nearest distance at which a ray of the tile crosses each;
 *  - in a leaf, the quads of one plane are skipped when the plane lies behind the eye or
 *    beyond every ray's hit, and a quad is skipped when it lies outside the rectangle in
 *    which the tile's rays cross its plane; one inside is tested on the units whose own
 *    rectangles it touches and whose rays may cross the plane before their own hits.
 * Whatever survives is tested ray by ray with exactly the arithmetic of trace_core.h
 * (vis_quad_intersect, vis_test_tri), and each ray keeps the minimum (t, ID) of what it
 * tested. The skips are conservative -- widened well past any rounding -- so a skipped
 * primitive could not have been hit by any ray of the tile, or could not have won: every
 * pixel equals vis_trace_pixel's (the brute-force reference and the OpenCL kernel), which
 * the tests check.
 *
 * The lane loops are written for the compiler to vectorise, a unit of 8 lanes at a time (the
 * min/max reductions, which it does not vectorise, in GCC's generic vectors); on
 * x86-64 with GCC the tile function is also built for AVX2 and picked at load time (define
 * VIS_NO_TARGET_CLONES for the baseline build only). No FMA is contracted
 * (-ffp-contract=off), so a lane computes exactly what a scalar ray does. docs/traversal.md
 * has the measurements behind the tile size, the units and the culls.
 *
 * The effects instance (packet_fx_*.c define PK_EFFECTS, and VIS_TRACE_EFFECTS before any
 * include, docs/effects.md): the same walk for the primary rays of an effects pass. Each lane
 * also keeps its hit primitive (axis | flags << 2, plane: ties in (t, ID) go on to it, as in
 * vis_hit_offer_prim) for its secondary rays; with the see-through effect, a see-through quad
 * never becomes a lane's hit and is offered instead to the lane's list of see-through objects
 * (vis_see_through_offer, the per-ray code's own state) wherever it crosses no farther than
 * the lane's hit. The culls only drop what lies beyond every hit it could beat, and the hit
 * is the opaque one, so every crossing that beats it is offered as in the per-ray methods,
 * and each lane's pixel is finished by the per-ray code (vis_effects_finish: the cut to the
 * crossings before the hit, then the reflected and shadow rays, traced alone). */
#include <limits.h>
#include <math.h>
#include <string.h>

#include "cpu/packet.h"
#ifdef PK_EFFECTS
#  include "cpu/effects.h"
#endif

#if !defined(PK_TILE_W) || !defined(PK_TILE_H) || !defined(PK_ENTRY)
#  error "define PK_TILE_W, PK_TILE_H and PK_ENTRY before including packet_impl.h"
#endif
#if defined(PK_EFFECTS) != defined(VIS_TRACE_EFFECTS)
#  error "the effects instance defines both PK_EFFECTS and VIS_TRACE_EFFECTS, the plain one neither"
#endif

#define LANES (PK_TILE_W * PK_TILE_H)
/* Lanes culled and tested together: one AVX2 vector (all lanes of a smaller tile). A unit is
 * a UNIT_W x (UNIT / UNIT_W) block of pixels: compact blocks cross a plane in a small
 * rectangle, so few quads reach a unit's lanes. */
#define UNIT (LANES < 8 ? LANES : 8)
#define UNIT_W (PK_TILE_W < 4 ? PK_TILE_W : 4)
#define UNITS (LANES / UNIT)
#define ALL_UNITS (UNITS == 32 ? 0xFFFFFFFFu : (1u << UNITS) - 1u)

/* Relative widening of t bounds computed from intervals (the exact per-ray distances differ
 * from them by a few ulps) and of rectangles (by more than any rounding of a crossing point).
 * The quad test is conservative (vis_quad_intersect): it takes a quad whose box the exact
 * float ray misses by up to about 2^-19 of |t d| (the slack of 2^-20 on distances, plus their
 * rounding); the rectangles here are widened by 2^-16 of at least |t d[u]|, and boxes by
 * 2^-15 of the scene's extent (|t d| to a hit is at most twice that), so both still cover
 * every quad a lane can take. */
#define T_SLACK 9.5367431640625e-07f  /* 2^-20 */
#define XY_SLACK 1.52587890625e-05f   /* 2^-16 */

typedef struct packet {
    float d[3][LANES], inv[3][LANES]; /* per ray, exactly as vis_ray_for_pixel makes them     */
    float best_t[LANES];
    uint32_t best_id[LANES], best_obj[LANES];
    float plane_t[LANES];    /* distance to the current plane                              */
    float o[3];
    float t_near, t_far;
    int sign[3];             /* +1: every ray has d > 0 on that axis, -1: every d < 0, 0: mixed */
    int axes[3];             /* the axes by lane LANES / 2's |d| (the tile's left edge, half way
                                down), largest first                                           */
    float dmin[3], dmax[3];  /* direction bounds                                            */
    float imin[3], imax[3];  /* 1/d bounds, where sign != 0                                 */
    float rlo[3][3], rhi[3][3]; /* d[b] / d[a] bounds (as d[b] * inv[a]), where sign[a] != 0 */
    float unit_rlo[3][3][UNITS], unit_rhi[3][3][UNITS]; /* the same for each unit of 8 lanes */
    int ratio_units;         /* bit a: unit_rlo/unit_rhi[a] are made (packet_ratio_units)     */
    int leaf_bounds;         /* unit_imin/unit_imax and rlo/rhi are made (packet_leaf_bounds) */
    float unit_imin[3][UNITS], unit_imax[3][UNITS];      /* 1/d bounds of each unit             */
    float unit_best[UNITS];  /* the farthest best hit of each unit (+inf while a lane has none) */
    float slack;             /* absolute widening of boxes                                  */
    float max_best;          /* the farthest best hit over the lanes (+inf while one has none) */
    int unhit;               /* lanes without a hit yet                                     */
    float give_up_t;         /* a first leaf entered past this: the tile is far (packet.c)  */
    int max_leaves;          /* leaves it may enter before it gives up (packet.c)           */
    int counting;            /* vis_trace_cost: count nodes opened and tests per lane        */
    uint32_t nodes;
    uint32_t tests[LANES];
    int leaves_entered;
    int given_up;
#ifdef PK_EFFECTS
    uint32_t best_prim[LANES]; /* the hit primitive: axis | flags << 2 (3: a triangle)     */
    float best_plane[LANES];   /* and its plane (0 for triangles)                          */
    int see_through;           /* VIS_FX_SEE_THROUGH: see-through quads are recorded, not hit */
    vis_hit fx[LANES];         /* with see_through: each lane's see-through list and reflector */
#endif
} packet;

#if defined(VIS_PACKET_PROFILE) /* every step its own symbol, for perf */
#  define PK_INLINE static __attribute__((noinline))
#elif defined(__GNUC__)
#  define PK_INLINE static inline __attribute__((always_inline))
#else
#  define PK_INLINE static inline
#endif

/* The pixel of lane i within the tile: units of UNIT_W x (UNIT / UNIT_W) pixels, row-major. */
static inline uint32_t lane_x(int i)
{
    int unit = i / UNIT, j = i % UNIT;
    return (uint32_t)((unit % (PK_TILE_W / UNIT_W)) * UNIT_W + j % UNIT_W);
}

static inline uint32_t lane_y(int i)
{
    int unit = i / UNIT, j = i % UNIT;
    return (uint32_t)((unit / (PK_TILE_W / UNIT_W)) * (UNIT / UNIT_W) + j / UNIT_W);
}

static inline float pk_min(float a, float b) { return a < b ? a : b; }
static inline float pk_max(float a, float b) { return a > b ? a : b; }

/* The pixel centres of vis_ray_for_pixel, (2x+1)/W - 1 and 1 - (2y+1)/H, once per column and
 * row of the tile (pixels past the image edge repeat the last one), laid out as the lanes of a
 * unit take them: a unit column's lanes' nx and a unit row's lanes' ny. */
PK_INLINE void packet_pixel_centres(const vis_ray_setup *s, uint32_t x0, uint32_t y0,
                                    float unit_nx[PK_TILE_W / UNIT_W][UNIT],
                                    float unit_ny[PK_TILE_H / (UNIT / UNIT_W)][UNIT])
{
    float nx[PK_TILE_W], ny[PK_TILE_H];
    for (int c = 0; c < PK_TILE_W; ++c) {
        uint32_t x = x0 + (uint32_t)c;
        x = x < s->width ? x : s->width - 1u;
        nx[c] = (float)(int32_t)(2u * x + 1u) / (float)(int32_t)s->width - 1.0f;
    }
    for (int r = 0; r < PK_TILE_H; ++r) {
        uint32_t y = y0 + (uint32_t)r;
        y = y < s->height ? y : s->height - 1u;
        ny[r] = 1.0f - (float)(int32_t)(2u * y + 1u) / (float)(int32_t)s->height;
    }
    for (int uc = 0; uc < PK_TILE_W / UNIT_W; ++uc)
        for (int j = 0; j < UNIT; ++j)
            unit_nx[uc][j] = nx[uc * UNIT_W + j % UNIT_W];
    for (int ur = 0; ur < PK_TILE_H / (UNIT / UNIT_W); ++ur)
        for (int j = 0; j < UNIT; ++j)
            unit_ny[ur][j] = ny[ur * (UNIT / UNIT_W) + j / UNIT_W];
}

PK_INLINE void packet_rays(packet *p, const vis_ray_setup *s, uint32_t x0, uint32_t y0)
{
    /* vis_ray_for_pixel, lane by lane, a unit at a time (the lanes of lane_x, lane_y). */
    float unit_nx[PK_TILE_W / UNIT_W][UNIT], unit_ny[PK_TILE_H / (UNIT / UNIT_W)][UNIT];
    packet_pixel_centres(s, x0, y0, unit_nx, unit_ny);
    for (int ur = 0; ur < PK_TILE_H / (UNIT / UNIT_W); ++ur)
        for (int uc = 0; uc < PK_TILE_W / UNIT_W; ++uc) {
            int i0 = (ur * (PK_TILE_W / UNIT_W) + uc) * UNIT;
            for (int j = 0; j < UNIT; ++j) {
                float nx = unit_nx[uc][j], ny = unit_ny[ur][j];
                float d0 = (s->forward[0] + nx * s->right[0]) + ny * s->up[0];
                float d1 = (s->forward[1] + nx * s->right[1]) + ny * s->up[1];
                float d2 = (s->forward[2] + nx * s->right[2]) + ny * s->up[2];
                float len = sqrtf(d0 * d0 + d1 * d1 + d2 * d2);
                p->d[0][i0 + j] = vis_dir_component(d0 / len);
                p->d[1][i0 + j] = vis_dir_component(d1 / len);
                p->d[2][i0 + j] = vis_dir_component(d2 / len);
            }
        }
    for (int a = 0; a < 3; ++a)
        for (int i = 0; i < LANES; ++i)
            p->inv[a][i] = 1.0f / p->d[a][i];
    for (int i = 0; i < LANES; ++i) {
        p->best_t[i] = INFINITY;
        p->best_id[i] = 0u;
        p->best_obj[i] = VIS_NO_OBJECT;
    }
    p->max_best = INFINITY;
    for (int r = 0; r < UNITS; ++r)
        p->unit_best[r] = INFINITY;
    p->unhit = LANES;
    p->give_up_t = INFINITY;
    p->max_leaves = INT_MAX;
    p->counting = 0;
    p->nodes = 0; /* tests[] is zeroed where the pass counts (PK_ENTRY) */
    p->leaves_entered = 0;
    p->given_up = 0;
    p->ratio_units = 0;
    float extent = 1.0f;
    for (int a = 0; a < 3; ++a) {
        p->o[a] = s->origin[a];
        extent = pk_max(extent, pk_max(fabsf(s->origin[a]), s->size[a]));
    }
    p->t_near = s->t_near;
    p->t_far = s->t_far;
    p->slack = 2.0f * extent * XY_SLACK;
}

/* The lane bounds below reduce 8 lanes at a time in GCC's generic vectors (one AVX2 register;
 * two SSE ones in the baseline build): under -fno-fast-math the compiler does not vectorise a
 * float min/max reduction on its own, and these bounds were a fifth of a near view's
 * instructions (docs/performance.md, "Near views: fewer instructions per ray"). PK_VMIN is
 * a < b ? a : b per element, written as a select (C has no vector ?:). Over values without NaN
 * (every d, 1/d, d[b] / d[a] and best t bounded here) a minimum or maximum is the same in any order up
 * to the sign of a zero, which no use of these bounds tells apart (they are only compared, or
 * multiplied and added to the eye, where -0 and +0 give equal values). */
#if defined(__GNUC__) && !defined(__clang__) && UNIT == 8
#  define PK_VECTORS 1
typedef float pk_v8 __attribute__((vector_size(32)));
typedef int pk_v8i __attribute__((vector_size(32))); /* the type a float vector compare gives */
_Static_assert(sizeof(int) == 4, "pk_v8i holds 8 lanes of a float compare's mask");
#  define PK_VSEL(m, a, b) ((pk_v8)(((m) & (pk_v8i)(a)) | (~(m) & (pk_v8i)(b))))
#  define PK_VMIN(a, b) PK_VSEL((a) < (b), a, b)
#  define PK_VMAX(a, b) PK_VSEL((a) > (b), a, b)
#endif

/* Minimum and maximum of the lanes of x, or of x[i] * y[i] where y is given (the products
 * rounded as the caller's own loops round them). */
PK_INLINE void pk_bounds_product(const float *x, const float *y, float *lo_out, float *hi_out)
{
    float lo[UNIT], hi[UNIT];
#if defined(PK_VECTORS) && LANES % (2 * UNIT) == 0
    /* Two chains of 8 lanes, for fewer loop steps. */
    pk_v8 lo0, lo1, hi0, hi1;
    for (int i = 0; i < LANES; i += 2 * UNIT) {
        pk_v8 v0, v1;
        memcpy(&v0, x + i, sizeof v0);
        memcpy(&v1, x + i + UNIT, sizeof v1);
        if (y) {
            pk_v8 w0, w1;
            memcpy(&w0, y + i, sizeof w0);
            memcpy(&w1, y + i + UNIT, sizeof w1);
            v0 = v0 * w0;
            v1 = v1 * w1;
        }
        lo0 = i == 0 ? v0 : PK_VMIN(lo0, v0);
        hi0 = i == 0 ? v0 : PK_VMAX(hi0, v0);
        lo1 = i == 0 ? v1 : PK_VMIN(lo1, v1);
        hi1 = i == 0 ? v1 : PK_VMAX(hi1, v1);
    }
    lo0 = PK_VMIN(lo0, lo1);
    hi0 = PK_VMAX(hi0, hi1);
    memcpy(lo, &lo0, sizeof lo);
    memcpy(hi, &hi0, sizeof hi);
#else
    for (int j = 0; j < UNIT; ++j)
        lo[j] = hi[j] = y ? x[j] * y[j] : x[j];
    for (int i = UNIT; i < LANES; i += UNIT)
        for (int j = 0; j < UNIT; ++j) {
            float v = y ? x[i + j] * y[i + j] : x[i + j];
            lo[j] = pk_min(lo[j], v);
            hi[j] = pk_max(hi[j], v);
        }
#endif
    float l = lo[0], h = hi[0];
    for (int j = 1; j < UNIT; ++j) {
        l = pk_min(l, lo[j]);
        h = pk_max(h, hi[j]);
    }
    *lo_out = l;
    *hi_out = h;
}

/* Minimum and maximum of the lanes. */
PK_INLINE void pk_bounds(const float *x, float *lo_out, float *hi_out) { pk_bounds_product(x, NULL, lo_out, hi_out); }

#if defined(PK_VECTORS) && UNITS % 8 == 0
/* Minimum and maximum of each unit of 8 lanes, 8 units at a time: each step pairs two vectors,
 * halving the lanes left per unit and doubling the units per vector, until one vector holds
 * the 8 units' bounds (a transpose that reduces as it goes). */
#  define PK_SHUF(a, b, ...) __builtin_shuffle(a, b, (pk_v8i){__VA_ARGS__})
PK_INLINE void pk_unit_bounds(const float *x, float *lo, float *hi)
{
    /* The shuffles are single AVX instructions (vperm2f128, vshufps; vpermps to put the units
     * back in order at the end); the comments give the units each vector's lanes hold. */
    for (int g = 0; g < UNITS; g += 8) {
        pk_v8 v[8], l1[4], h1[4], l2[2], h2[2];
        memcpy(v, x + g * UNIT, sizeof v);
        for (int k = 0; k < 4; ++k) { /* 2k x4, 2k+1 x4 */
            pk_v8 a = PK_SHUF(v[2 * k], v[2 * k + 1], 0, 1, 2, 3, 8, 9, 10, 11);
            pk_v8 b = PK_SHUF(v[2 * k], v[2 * k + 1], 4, 5, 6, 7, 12, 13, 14, 15);
            l1[k] = PK_VMIN(a, b);
            h1[k] = PK_VMAX(a, b);
        }
        for (int k = 0; k < 2; ++k) { /* 4k x2, 4k+2 x2, 4k+1 x2, 4k+3 x2 */
            pk_v8 la = PK_SHUF(l1[2 * k], l1[2 * k + 1], 0, 1, 8, 9, 4, 5, 12, 13);
            pk_v8 lb = PK_SHUF(l1[2 * k], l1[2 * k + 1], 2, 3, 10, 11, 6, 7, 14, 15);
            pk_v8 ha = PK_SHUF(h1[2 * k], h1[2 * k + 1], 0, 1, 8, 9, 4, 5, 12, 13);
            pk_v8 hb = PK_SHUF(h1[2 * k], h1[2 * k + 1], 2, 3, 10, 11, 6, 7, 14, 15);
            l2[k] = PK_VMIN(la, lb);
            h2[k] = PK_VMAX(ha, hb);
        }
        /* 0, 2, 4, 6, 1, 3, 5, 7 */
        pk_v8 la = PK_SHUF(l2[0], l2[1], 0, 2, 8, 10, 4, 6, 12, 14), lb = PK_SHUF(l2[0], l2[1], 1, 3, 9, 11, 5, 7, 13, 15);
        pk_v8 ha = PK_SHUF(h2[0], h2[1], 0, 2, 8, 10, 4, 6, 12, 14), hb = PK_SHUF(h2[0], h2[1], 1, 3, 9, 11, 5, 7, 13, 15);
        pk_v8 l = PK_VMIN(la, lb), h = PK_VMAX(ha, hb);
        l = PK_SHUF(l, l, 0, 4, 1, 5, 2, 6, 3, 7);
        h = PK_SHUF(h, h, 0, 4, 1, 5, 2, 6, 3, 7);
        memcpy(lo + g, &l, sizeof l);
        memcpy(hi + g, &h, sizeof h);
    }
}
#else
/* Minimum and maximum of each unit of 8 lanes. */
PK_INLINE void pk_unit_bounds(const float *x, float *lo, float *hi)
{
    for (int r = 0; r < UNITS; ++r) {
        float l = x[r * UNIT], h = l;
        for (int i = 1; i < UNIT; ++i) {
            l = pk_min(l, x[r * UNIT + i]);
            h = pk_max(h, x[r * UNIT + i]);
        }
        lo[r] = l;
        hi[r] = h;
    }
}
#endif

/* The interval bounds of the tile's directions, which its walk through the tree needs. */
PK_INLINE void packet_bounds(packet *p)
{
    for (int a = 0; a < 3; ++a) {
        float lo, hi;
        pk_bounds(p->d[a], &lo, &hi);
        /* Where every d has one sign, 1/d falls as d rises, and so does its rounding: the
         * lanes' 1/d = inv lie in [1/hi, 1/lo], which are two lanes' own values. */
        float ilo = 1.0f / hi, ihi = 1.0f / lo;
        p->dmin[a] = lo;
        p->dmax[a] = hi;
        /* A strict common sign with finite inverses; anything else is "mixed". */
        p->sign[a] = (lo > 0.0f || hi < 0.0f) && isfinite(ilo) && isfinite(ihi) ? (lo > 0.0f ? 1 : -1) : 0;
        p->imin[a] = ilo;
        p->imax[a] = ihi;
    }
    /* The axes by lane LANES / 2's |d| (the left edge's middle pixel), largest first: a leaf's
     * planes are walked in this order unless y comes last (packet_leaf). */
    float m[3];
    for (int a = 0; a < 3; ++a)
        m[a] = fabsf(p->d[a][LANES / 2]);
    int first = m[1] > m[0] ? 1 : 0;
    first = m[2] > m[first] ? 2 : first;
    int b = first == 0 ? 1 : 0, c = 3 - first - b;
    p->axes[0] = first;
    p->axes[1] = m[c] > m[b] ? c : b;
    p->axes[2] = m[c] > m[b] ? b : c;
    p->leaf_bounds = 0;
}

/* The bounds only a leaf's walk reads, made when the tile enters its first leaf (a tile of
 * sky enters none): each unit's 1/d bounds, and the tile's d[b] / d[a] bounds. */
PK_INLINE void packet_leaf_bounds(packet *p)
{
    if (p->leaf_bounds)
        return;
    p->leaf_bounds = 1;
    for (int a = 0; a < 3; ++a)
        pk_unit_bounds(p->inv[a], p->unit_imin[a], p->unit_imax[a]);
    for (int a = 0; a < 3; ++a) {
        if (p->sign[a] == 0)
            continue;
        for (int b = 0; b < 3; ++b) {
            if (b == a)
                continue;
            pk_bounds_product(p->d[b], p->inv[a], &p->rlo[a][b], &p->rhi[a][b]);
        }
    }
}

/* The units' d[b] / d[a] bounds for the two other axes b of axis a (sign[a] != 0), made the
 * first time a quad on a plane of axis a passes the tile's rectangle: on near views most tiles
 * never get there on some axes, or on any. */
PK_INLINE void packet_ratio_units(packet *p, int a)
{
    if (p->ratio_units >> a & 1)
        return;
    p->ratio_units |= 1 << a;
    for (int b = 0; b < 3; ++b) {
        if (b == a)
            continue;
        float r[LANES];
        for (int i = 0; i < LANES; ++i)
            r[i] = p->d[b][i] * p->inv[a][i];
        pk_unit_bounds(r, p->unit_rlo[a][b], p->unit_rhi[a][b]);
    }
}

/* The farthest best hit, from the units' (each the maximum of its lanes, kept by every step
 * that changes a lane's hit): 32 values to reduce instead of 256. */
PK_INLINE void packet_update_max_best(packet *p)
{
    if (p->unhit > 0)
        return; /* still +inf */
    float m = p->unit_best[0];
    for (int r = 1; r < UNITS; ++r)
        m = pk_max(m, p->unit_best[r]);
    p->max_best = m;
}

/* Narrows [*t0, *t1] to where the tile's rays can be inside the slab [lo, hi] (widened by
 * the slack) of axis a: interval bounds on each ray's entry and exit distances. Returns 0 when
 * no ray can enter it. */
/* Where the slab [lo, hi] (widened) of an axis whose rays all move one way (sign != 0)
 * begins and ends, as offsets from the eye along that axis: a ray's entry and exit distances
 * are these times its 1/d. */
PK_INLINE void packet_slab_offsets(const packet *p, int a, float lo, float hi, float *cin, float *cout)
{
    float l = lo - p->slack - p->o[a], h = hi + p->slack - p->o[a];
    *cin = p->sign[a] > 0 ? l : h;
    *cout = p->sign[a] > 0 ? h : l;
}

PK_INLINE int packet_slab(const packet *p, int a, float lo, float hi, float *t0, float *t1)
{
    float l = lo - p->slack, h = hi + p->slack, o = p->o[a];
    if (p->sign[a] != 0) {
        float cin, cout;
        packet_slab_offsets(p, a, lo, hi, &cin, &cout);
        *t0 = pk_max(*t0, pk_min(cin * p->imin[a], cin * p->imax[a]));
        *t1 = pk_min(*t1, pk_max(cout * p->imin[a], cout * p->imax[a]));
    } else if (o < l) {
        if (!(p->dmax[a] > 0.0f))
            return 0; /* no ray moves toward the slab */
        *t0 = pk_max(*t0, (l - o) / p->dmax[a]);
    } else if (o > h) {
        if (!(p->dmin[a] < 0.0f))
            return 0;
        *t0 = pk_max(*t0, (h - o) / p->dmin[a]);
    }
    return 1;
}

/* Whether some ray of the tile may have a hit better than its own in the closed box
 * [lo, hi]: the box, widened by the slack, is met within [t_near, t_far] and no farther
 * than the farthest best hit. */
PK_INLINE int packet_box_open(const packet *p, const float *lo, const float *hi)
{
    float t0 = p->t_near, t1 = p->t_far;
    for (int a = 0; a < 3; ++a)
        if (!packet_slab(p, a, lo[a], hi[a], &t0, &t1))
            return 0;
    t0 -= t0 * T_SLACK;
    return t0 <= t1 + fabsf(t1) * T_SLACK && t0 <= p->max_best + p->max_best * T_SLACK;
}

/* The units whose rays may enter the closed box [lo, hi] (widened by the slack) within
 * [t_near, t_far], no farther than their own farthest best hit: packet_box_open, per unit. */
PK_INLINE uint32_t packet_box_units(const packet *p, const float *lo, const float *hi)
{
    float t0[UNITS], t1[UNITS];
    for (int j = 0; j < UNITS; ++j) {
        t0[j] = p->t_near;
        t1[j] = p->t_far;
    }
    for (int a = 0; a < 3; ++a) {
        if (p->sign[a] != 0) {
            float cin, cout;
            packet_slab_offsets(p, a, lo[a], hi[a], &cin, &cout);
            for (int j = 0; j < UNITS; ++j) {
                t0[j] = pk_max(t0[j], pk_min(cin * p->unit_imin[a][j], cin * p->unit_imax[a][j]));
                t1[j] = pk_min(t1[j], pk_max(cout * p->unit_imin[a][j], cout * p->unit_imax[a][j]));
            }
        } else {
            /* Directions of both signs: the whole tile's bound serves every unit. */
            float te0 = -INFINITY, te1 = INFINITY;
            if (!packet_slab(p, a, lo[a], hi[a], &te0, &te1))
                return 0;
            for (int j = 0; j < UNITS; ++j)
                t0[j] = pk_max(t0[j], te0);
        }
    }
    int in[UNITS];
    for (int j = 0; j < UNITS; ++j) {
        float a0 = t0[j] - t0[j] * T_SLACK;
        in[j] = (a0 <= t1[j] + fabsf(t1[j]) * T_SLACK) & (a0 <= p->unit_best[j] + p->unit_best[j] * T_SLACK);
    }
    uint32_t units = 0;
    for (int j = 0; j < UNITS; ++j)
        units |= (uint32_t)in[j] << j;
    return units;
}

/* The distance to `plane` on axis a of the lanes of the units in `units`, with
 * vis_quad_intersect's expression. */
PK_INLINE void packet_cross_plane(packet *p, int a, float plane, uint32_t units)
{
    float c = plane - p->o[a];
    for (; units; units &= units - 1u)
        for (int i = __builtin_ctz(units) * UNIT, e = i + UNIT; i < e; ++i)
            p->plane_t[i] = c * p->inv[a][i];
}

/* vis_slab for one lane: narrows [*t_in, *t_out] to the slab [lo, hi] of an axis (cl = lo - o,
 * ch = hi - o, the lane's d and 1/d on it); 0 when a ray parallel to it lies outside. */
static inline int pk_slab(float cl, float ch, float d, float inv, float *t_in, float *t_out)
{
    float t_lo = cl * inv, t_hi = ch * inv;
    float t0 = d > 0.0f ? t_lo : t_hi, t1 = d > 0.0f ? t_hi : t_lo;
    int par = d == 0.0f;
    t0 = par ? -INFINITY : t0;
    t1 = par ? INFINITY : t1;
    *t_in = t0 > *t_in ? t0 : *t_in;
    *t_out = t1 < *t_out ? t1 : *t_out;
    return (par == 0) | ((cl <= 0.0f) & (ch >= 0.0f));
}

/* vis_test_quad for the lanes of the units in `units` (bit j: lanes 8j..8j+7), with the
 * distance from packet_cross_plane: the slab test of the quad's box, operation for operation
 * (a parallel ray's slab is all or nothing, as in vis_slab). Returns whether a lane took the
 * quad. */
PK_INLINE int packet_test_quad(packet *p, int a, const vis_flat_quad *q, uint32_t id, uint32_t units)
{
    int u = a == 2 ? 0 : a + 1, v = a == 0 ? 2 : a - 1;
    float cu0 = q->u0 - p->o[u], cu1 = q->u1 - p->o[u], cv0 = q->v0 - p->o[v], cv1 = q->v1 - p->o[v];
    float tn = p->t_near, tf = p->t_far;
    uint32_t obj = VIS_META_OBJECT(q->meta);
    int any = 0, first_hits = 0;
#ifdef PK_EFFECTS
    uint32_t prim = q->meta & 0xFFu; /* axis | flags << 2 */
    float qplane = q->plane;
    if (p->see_through && (VIS_META_FLAGS(q->meta) & VIS_FLAG_SEE_THROUGH)) {
        /* A crossing no farther than the lane's hit joins its list (vis_test_quad's bounds);
         * the hits and their culls stay as they are. */
        for (; units; units &= units - 1u) {
            int first = __builtin_ctz(units) * UNIT;
            for (int i = first; i < first + UNIT; ++i) {
                float t = p->plane_t[i], t_in = t, t_out = t;
                int in_u = pk_slab(cu0, cu1, p->d[u][i], p->inv[u][i], &t_in, &t_out);
                int in_v = pk_slab(cv0, cv1, p->d[v][i], p->inv[v][i], &t_in, &t_out);
                if ((p->d[a][i] != 0.0f) & in_u & in_v & (t_in <= vis_t_limit(t_out)) & (t >= tn) & (t <= tf) &
                    (t <= p->best_t[i]))
                    vis_see_through_offer(t, id, prim, qplane, &p->fx[i]);
            }
        }
        return 0;
    }
#endif
    for (; units; units &= units - 1u) {
        int first = __builtin_ctz(units) * UNIT, unit_hit = 0;
        if (p->counting)
            for (int i = first; i < first + UNIT; ++i)
                ++p->tests[i];
        for (int i = first; i < first + UNIT; ++i) {
            float t = p->plane_t[i], bt = p->best_t[i], t_in = t, t_out = t;
            int in_u = pk_slab(cu0, cu1, p->d[u][i], p->inv[u][i], &t_in, &t_out);
            int in_v = pk_slab(cv0, cv1, p->d[v][i], p->inv[v][i], &t_in, &t_out);
#ifdef PK_EFFECTS
            /* vis_prim_better: (t, ID), then the primitive. */
            uint32_t bid = p->best_id[i], bprim = p->best_prim[i];
            int tie_prim = (prim < bprim) | ((prim == bprim) & (qplane < p->best_plane[i]));
            int better = (t < bt) | ((t == bt) & ((id < bid) | ((id == bid) & tie_prim)));
#else
            int better = (t < bt) | ((t == bt) & (id < p->best_id[i]));
#endif
            int m = (p->d[a][i] != 0.0f) & in_u & in_v & (t_in <= vis_t_limit(t_out)) & (t >= tn) & (t <= tf) &
                    better;
            p->best_t[i] = m ? t : bt;
            p->best_id[i] = m ? id : p->best_id[i];
            p->best_obj[i] = m ? obj : p->best_obj[i];
#ifdef PK_EFFECTS
            p->best_prim[i] = m ? prim : bprim;
            p->best_plane[i] = m ? qplane : p->best_plane[i];
#endif
            unit_hit |= m;
            first_hits += m & (bt == INFINITY);
        }
        if (!unit_hit)
            continue; /* the unit's hits, and so its farthest, are as they were */
        any = 1;
        float ub = p->best_t[first];
        for (int i = first + 1; i < first + UNIT; ++i)
            ub = pk_max(ub, p->best_t[i]);
        p->unit_best[first / UNIT] = ub;
    }
    p->unhit -= first_hits;
    return any;
}

/* Lane i as the per-ray code sees it: its ray and its best hit so far. */
PK_INLINE void packet_lane(const packet *p, int i, vis_ray *r, vis_hit *h)
{
    for (int a = 0; a < 3; ++a) {
        r->o[a] = p->o[a];
        r->d[a] = p->d[a][i];
        r->inv[a] = p->inv[a][i];
    }
    r->t_near = p->t_near;
    r->t_far = p->t_far;
#ifdef PK_EFFECTS
    if (p->see_through)
        *h = p->fx[i];
    else
        vis_hit_init(h, VIS_ST_OCCLUDE, 0u, VIS_NO_AXIS, 0.0f);
    h->prim = p->best_prim[i];
    h->plane = p->best_plane[i];
#endif
    h->t = p->best_t[i];
    h->object = p->best_obj[i];
    h->id = p->best_id[i];
}

/* A quad tested on its own (loose quads): cull by its box, then every lane. */
PK_INLINE void packet_loose_quad(packet *p, const vis_flat_quad *q, const vis_flat_object *objects)
{
    int a = (int)VIS_META_AXIS(q->meta), u = a == 2 ? 0 : a + 1, v = a == 0 ? 2 : a - 1;
    float lo[3], hi[3];
    lo[a] = hi[a] = q->plane;
    lo[u] = q->u0, hi[u] = q->u1, lo[v] = q->v0, hi[v] = q->v1;
    if (!packet_box_open(p, lo, hi))
        return;
    packet_cross_plane(p, a, q->plane, ALL_UNITS);
    if (packet_test_quad(p, a, q, objects[VIS_META_OBJECT(q->meta)].id, ALL_UNITS))
        packet_update_max_best(p);
}

/* A triangle: cull by its box, then vis_test_tri ray by ray. */
PK_INLINE void packet_triangle(packet *p, const vis_flat_tri *tri, const vis_flat_object *objects)
{
    float lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
        lo[a] = pk_min(tri->v0[a], pk_min(tri->v1[a], tri->v2[a]));
        hi[a] = pk_max(tri->v0[a], pk_max(tri->v1[a], tri->v2[a]));
    }
    if (!packet_box_open(p, lo, hi))
        return;
    for (int i = 0; i < LANES; ++i) {
        vis_ray r;
        vis_hit h;
        packet_lane(p, i, &r, &h);
        if (p->counting)
            ++p->tests[i];
        vis_test_tri(&r, tri, objects, &h);
        p->unhit -= p->best_t[i] == INFINITY && h.t != INFINITY;
        p->best_t[i] = h.t;
        p->best_obj[i] = h.object;
        p->best_id[i] = h.id;
#ifdef PK_EFFECTS
        p->best_prim[i] = h.prim;
        p->best_plane[i] = h.plane;
        if (p->see_through)
            p->fx[i] = h; /* its see-through list and reflector */
#endif
    }
    float unit_lo[UNITS];
    pk_unit_bounds(p->best_t, unit_lo, p->unit_best);
    packet_update_max_best(p);
}

/* Where the lanes cross a plane c = plane - o[a] away from the eye on axis a: a rectangle for
 * the whole tile and, made when a quad reaches them, one for each unit of 8 lanes. Widened
 * past any rounding of a lane's crossing point. Unbounded (every quad, every row) when the
 * tile's directions take both signs on the axis. */
typedef struct plane_bounds {
    int bounded;
    float c, mu, mv;
    float ulo, uhi, vlo, vhi;
    float unit_ulo[UNITS], unit_uhi[UNITS], unit_vlo[UNITS], unit_vhi[UNITS];
} plane_bounds;

/* The units that may still take a quad on the plane c = plane - o[a] away on axis a (sign[a]
 * != 0): a lane crosses it at t = c * inv, rounded, which lies between c * unit_imin and
 * c * unit_imax of its unit (rounding is monotone); where that bound lies past the unit's
 * farthest hit, or past t_far, no lane of the unit can take a quad there (the test needs t <=
 * t_far and (t, ID) below the lane's hit, so t no farther than it). Exact: no slack needed. */
PK_INLINE uint32_t packet_plane_units(const packet *p, int a, float c)
{
    int in[UNITS];
    for (int j = 0; j < UNITS; ++j) {
        float ta = c * p->unit_imin[a][j], tb = c * p->unit_imax[a][j];
        float tlo = pk_min(ta, tb);
        in[j] = (tlo <= p->unit_best[j]) & (tlo <= p->t_far);
    }
    uint32_t units = 0;
    for (int j = 0; j < UNITS; ++j)
        units |= (uint32_t)in[j] << j;
    return units;
}

PK_INLINE void plane_bounds_make(const packet *p, int a, float c, plane_bounds *pb)
{
    int u = a == 2 ? 0 : a + 1, v = a == 0 ? 2 : a - 1;
    float ra = c * p->rlo[a][u], rb = c * p->rhi[a][u];
    float sa = c * p->rlo[a][v], sb = c * p->rhi[a][v];
    pb->bounded = 1;
    pb->c = c;
    pb->mu = (fabsf(ra) + fabsf(rb) + fabsf(p->o[u]) + 1.0f) * XY_SLACK;
    pb->mv = (fabsf(sa) + fabsf(sb) + fabsf(p->o[v]) + 1.0f) * XY_SLACK;
    pb->ulo = p->o[u] + pk_min(ra, rb) - pb->mu;
    pb->uhi = p->o[u] + pk_max(ra, rb) + pb->mu;
    pb->vlo = p->o[v] + pk_min(sa, sb) - pb->mv;
    pb->vhi = p->o[v] + pk_max(sa, sb) + pb->mv;
}

PK_INLINE void plane_bounds_units(const packet *p, int a, plane_bounds *pb)
{
    int u = a == 2 ? 0 : a + 1, v = a == 0 ? 2 : a - 1;
    float c = pb->c, ou = p->o[u], ov = p->o[v], mu = pb->mu, mv = pb->mv;
    for (int j = 0; j < UNITS; ++j) {
        float ra = c * p->unit_rlo[a][u][j], rb = c * p->unit_rhi[a][u][j];
        float sa = c * p->unit_rlo[a][v][j], sb = c * p->unit_rhi[a][v][j];
        pb->unit_ulo[j] = ou + pk_min(ra, rb) - mu;
        pb->unit_uhi[j] = ou + pk_max(ra, rb) + mu;
        pb->unit_vlo[j] = ov + pk_min(sa, sb) - mv;
        pb->unit_vhi[j] = ov + pk_max(sa, sb) + mv;
    }
}

/* The quads of bucket [first, end) of axis a, culled by the tile's rectangle, then by the
 * units'. The bucket is sorted by u0 (scene.c): the scan stops at the first quad starting
 * past the tile's rectangle. */
PK_INLINE void packet_bucket(packet *p, int a, float plane, const vis_flat_leaf *leaf, const uint32_t *packed,
                             const uint32_t *table, uint32_t first, uint32_t end, const vis_flat_object *objects,
                             uint32_t leaf_units, plane_bounds *pb)
{
    int bounds = 0, hit = 0;
    uint32_t crossed = 0; /* units whose crossing of this plane is computed */
    uint32_t open = leaf_units; /* of those, units that may still beat a hit on this plane */
    int u = a == 2 ? 0 : a + 1, v = a == 0 ? 2 : a - 1;
    float lu = leaf->lo[u], lv = leaf->lo[v];
    for (uint32_t j = first; j < end; ++j) {
        uint32_t w = packed[j];
        vis_flat_quad qd;
        const vis_flat_quad *q = &qd;
        qd.plane = plane;
        qd.u0 = lu + (float)VIS_PQ_FIELD(w, 0u);
        qd.v0 = lv + (float)VIS_PQ_FIELD(w, 1u);
        qd.u1 = lu + (float)VIS_PQ_FIELD(w, 2u);
        qd.v1 = lv + (float)VIS_PQ_FIELD(w, 3u);
        uint32_t units = leaf_units;
        if (pb->bounded) {
            if (q->u0 > pb->uhi)
                break;
            if (q->u1 < pb->ulo || q->v0 > pb->vhi || q->v1 < pb->vlo)
                continue;
            if (!bounds) {
                packet_ratio_units(p, a);
                plane_bounds_units(p, a, pb);
                open &= packet_plane_units(p, a, pb->c);
                bounds = 1;
            }
            int in[UNITS];
            for (int r = 0; r < UNITS; ++r)
                in[r] = (q->u0 <= pb->unit_uhi[r]) & (q->u1 >= pb->unit_ulo[r]) & (q->v0 <= pb->unit_vhi[r]) &
                        (q->v1 >= pb->unit_vlo[r]);
            uint32_t near_units = 0;
            for (int r = 0; r < UNITS; ++r)
                near_units |= (uint32_t)in[r] << r;
            units &= near_units & open;
        }
        if (!units)
            continue;
        if (units & ~crossed) {
            packet_cross_plane(p, a, plane, units & ~crossed);
            crossed |= units;
        }
        uint32_t obj = table[VIS_PQ_TABLE(w)];
        qd.meta = obj << 8 | VIS_PQ_FLAGS(w) << 2 | (uint32_t)a;
        hit |= packet_test_quad(p, a, q, objects[obj].id, units);
    }
    if (hit)
        packet_update_max_best(p);
}

/* A plane offset clamped to [0, e] before the conversion (no overflow on far or infinite
 * values; NaN, impossible here, would give 0). */
static inline int pk_plane_index(float k, int e)
{
    if (!(k > 0.0f))
        return 0;
    return k < (float)e ? (int)k : e;
}

/* The part of a leaf where its packed quads can be hit: the leaf's box cut to its content box
 * (vis_flat_leaf.content_box, the box of every packed quad in the leaf's integer offsets),
 * as floats lo + offset, which are the quads' own coordinates (vis_unpack_quad), and the
 * range [kl[a], kh[a]] of planes on each axis that can hold a non-empty bucket. A high field
 * of 31 reads as "up to the leaf's last plane" (trace_core.h). Quads may reach past their
 * leaf, but a lane that takes one outside the leaf's box takes it in the neighbour that holds
 * it too (the walk visits that leaf for the lane), so the cut box serves the whole leaf. */
PK_INLINE void packet_content_box(const vis_flat_leaf *leaf, const int *E, float *lo, float *hi, int *kl, int *kh)
{
    uint32_t cb = leaf->content_box;
    for (int a = 0; a < 3; ++a) {
        int bl = (int)VIS_BOX_FIELD(cb, (uint32_t)a), bh = (int)VIS_BOX_FIELD(cb, (uint32_t)a + 3u);
        if (bh == (int)VIS_PQ_COORD_MAX && E[a] > bh)
            bh = E[a]; /* saturated */
        lo[a] = leaf->lo[a] + (float)bl;
        hi[a] = pk_min(leaf->hi[a], leaf->lo[a] + (float)bh);
        kh[a] = bh < E[a] ? bh : E[a];
        kl[a] = bl < kh[a] ? bl : kh[a];
    }
}

/* The next plane of axis a from *k on (stepping by `step` up to kend) whose bucket holds a quad
 * and which some ray crosses at or past t_near: leaves *k on it and returns the nearest
 * distance at which a ray crosses it (INFINITY when none is left). Each lane's t is c * inv,
 * rounded: monotone in inv, so c * imin and c * imax bound it exactly. */
PK_INLINE float packet_next_plane(const packet *p, int a, const vis_flat_leaf *leaf, const uint32_t *bk, int base,
                                  int *k, int kend, int step)
{
    for (; step > 0 ? *k <= kend : *k >= kend; *k += step) {
        uint32_t b = (uint32_t)(base + *k);
        if (bk[b] == bk[b + 1u])
            continue;
        float c = (leaf->lo[a] + (float)*k) - p->o[a];
        float ta = c * p->imin[a], tb = c * p->imax[a];
        if (pk_max(ta, tb) < p->t_near)
            continue; /* behind the eye or the near plane for every ray */
        return pk_min(ta, tb);
    }
    return INFINITY;
}

/* Plane k of axis a (sign[a] != 0): the quads of its bucket, where the tile's rays cross the
 * plane inside the content box [lo, hi] (widened). Rays crossing it outside cannot take a
 * quad of this leaf there that its neighbour, which holds the quad too, would not. */
PK_INLINE void packet_plane(packet *p, int a, int k, const vis_flat_leaf *leaf, const float *lo, const float *hi,
                            const uint32_t *packed, const uint32_t *table, const uint32_t *bk, int base,
                            const vis_flat_object *objects, uint32_t leaf_units, plane_bounds *pb)
{
    uint32_t b = (uint32_t)(base + k);
    float plane = leaf->lo[a] + (float)k;
    plane_bounds_make(p, a, plane - p->o[a], pb);
    int u = a == 2 ? 0 : a + 1, v = a == 0 ? 2 : a - 1;
    if (pb->uhi < lo[u] - p->slack || pb->ulo > hi[u] + p->slack || pb->vhi < lo[v] - p->slack ||
        pb->vlo > hi[v] + p->slack)
        return;
    packet_bucket(p, a, plane, leaf, packed, table, bk[b], bk[b + 1u], objects, leaf_units, pb);
}

PK_INLINE void packet_leaf(packet *p, const vis_scene_view *view, const vis_flat_leaf *leaf)
{
    const uint32_t *quads = view->quads;
    const vis_flat_object *objects = view->objects;
    packet_leaf_bounds(p);
    if (leaf->loose_count != 0u || leaf->tri_count != 0u) {
        /* Loose quads and triangles lie anywhere in the leaf: its whole box decides. */
        if (!packet_box_units(p, leaf->lo, leaf->hi))
            return;
        const vis_flat_quad *loose = vis_loose_quads(quads, leaf);
        for (uint32_t i = 0; i < leaf->loose_count; ++i)
            packet_loose_quad(p, &loose[i], objects);
        for (uint32_t i = 0; i < leaf->tri_count; ++i)
            packet_triangle(p, &view->tris[leaf->tri_offset + i], objects);
    }
    if (leaf->quad_count == 0u)
        return;
    int E[3] = {(int)(leaf->dims_xy & 0xFFFFu), (int)(leaf->dims_xy >> 16), (int)leaf->dims_z};
    float lo[3], hi[3];
    int kl[3], kh[3];
    packet_content_box(leaf, E, lo, hi, kl, kh);
    /* The units that can still take a packed quad here: those whose rays enter the content
     * box (widened) before their own farthest hit. A lane takes a quad at a point of the quad's
     * box, which lies in the content box, so every other unit is done before this leaf. */
    uint32_t leaf_units = packet_box_units(p, lo, hi);
    if (!leaf_units)
        return;
    int base[3] = {0, E[0] + 1, E[0] + E[1] + 2};
    const uint32_t *bk = view->buckets + leaf->bucket_offset;
    const uint32_t *packed = quads + leaf->quad_offset, *table = quads + leaf->table_offset;
    /* Where the tile's rays can be inside the content box (packet_box_units found it open). */
    float t0 = p->t_near, t1 = p->t_far;
    for (int a = 0; a < 3; ++a)
        if (!packet_slab(p, a, lo[a], hi[a], &t0, &t1))
            return;
    /* The walk goes near side first, so the first leaf the tile enters shows how far away its
     * hits lie; past give_up_t its rays spread over several leaves and go one by one. */
    if ((p->leaves_entered++ == 0 && t0 > p->give_up_t) || p->leaves_entered > p->max_leaves) {
        p->given_up = 1;
        return;
    }
    t0 -= t0 * T_SLACK;
    t1 += t1 * T_SLACK;
    plane_bounds pb;
    for (int a = 0; a < 3; ++a) {
        if (p->sign[a] != 0)
            continue;
        /* Directions on both sides of this axis (or along it): no bounds, every quad. */
        pb.bounded = 0;
        for (int k = kl[a]; k <= kh[a]; ++k) {
            uint32_t b = (uint32_t)(base[a] + k);
            packet_bucket(p, a, leaf->lo[a] + (float)k, leaf, packed, table, bk[b], bk[b + 1u], objects, leaf_units,
                          &pb);
        }
    }
    /* The other axes' planes from the one at or behind the eye, within the span the tile's rays
     * cover inside the content box (one plane wider each side): k[a] to kend[a] by step[a]. */
    int k[3] = {0, 0, 0}, kend[3] = {0, 0, 0}, step[3] = {1, 1, 1};
    for (int a = 0; a < 3; ++a) {
        if (p->sign[a] == 0)
            continue;
        float x0 = pk_min(pk_min(t0 * p->dmin[a], t0 * p->dmax[a]), pk_min(t1 * p->dmin[a], t1 * p->dmax[a]));
        float x1 = pk_max(pk_max(t0 * p->dmin[a], t0 * p->dmax[a]), pk_max(t1 * p->dmin[a], t1 * p->dmax[a]));
        int klo = pk_plane_index(floorf(p->o[a] + x0 - leaf->lo[a]) - 1.0f, E[a]);
        int khi = pk_plane_index(ceilf(p->o[a] + x1 - leaf->lo[a]) + 1.0f, E[a]);
        klo = klo > kl[a] ? klo : kl[a];
        khi = khi < kh[a] ? khi : kh[a];
        int eye = pk_plane_index(floorf(p->o[a] - leaf->lo[a]), E[a]);
        step[a] = p->sign[a];
        k[a] = step[a] > 0 ? (eye > klo ? eye : klo) : (eye + 1 < khi ? eye + 1 : khi);
        kend[a] = step[a] > 0 ? khi : klo;
    }
    /* Any order gives the same minimum; the order decides how soon hits close units. Axis by
     * axis, the axis the rays move along most first: seen from above, the tops carry most hits
     * and cut the other axes' planes short. In a level view (y the axis the rays move along
     * least: at street level, walls of x and z at interleaved depths) the planes of all axes go
     * in one sequence by the nearest distance at which a ray crosses them, so that a near wall
     * of either axis closes units before the far planes of the other are read: 4-5 % off
     * gen:city's walk-0 and walk-3 (docs/performance.md, "A leaf's planes in the order the rays
     * cross them, in level views"; merged wherever y is not the main axis, gen:default's
     * overview took 0.4-4.1 % longer, and merged everywhere 4.9 %). */
    if (p->axes[2] != 1) {
        for (int ai = 0; ai < 3; ++ai) {
            int a = p->axes[ai];
            if (p->sign[a] == 0)
                continue;
            /* In scalars, as the merge below keeps its state. */
            int ka = k[a], end = kend[a], st = step[a], ba = base[a];
            for (; st > 0 ? ka <= end : ka >= end; ka += st) {
                uint32_t b = (uint32_t)(ba + ka);
                if (bk[b] == bk[b + 1u])
                    continue;
                float c = (leaf->lo[a] + (float)ka) - p->o[a];
                float ta = c * p->imin[a], tb = c * p->imax[a];
                if (pk_max(ta, tb) < p->t_near)
                    continue; /* behind the eye or the near plane for every ray */
                float tlo = pk_min(ta, tb);
                if (tlo > p->t_far || tlo > p->max_best)
                    break;    /* this plane and every later one lie past every ray's hit */
                packet_plane(p, a, ka, leaf, lo, hi, packed, table, bk, ba, objects, leaf_units, &pb);
            }
        }
        return;
    }
    /* The next plane of each axis and the nearest distance at which a ray crosses it
     * (INFINITY: none left). The merge ends at the first plane past t_far or every ray's hit:
     * every plane left lies farther. */
    float tn[3];
    for (int a = 0; a < 3; ++a)
        tn[a] = p->sign[a] == 0 ? INFINITY : packet_next_plane(p, a, leaf, bk, base[a], &k[a], kend[a], step[a]);
    /* The merge's state in scalars: with it in the arrays above, indexed by the axis chosen,
     * gen:default's walk-2 took 5-7 % longer for 6 % fewer instructions. */
    float n0 = tn[0], n1 = tn[1], n2 = tn[2];
    int k0 = k[0], k1 = k[1], k2 = k[2];
    for (;;) {
        int a = n0 <= n1 && n0 <= n2 ? 0 : n1 <= n2 ? 1 : 2;
        float tlo = a == 0 ? n0 : a == 1 ? n1 : n2;
        if (tlo == INFINITY || tlo > p->t_far || tlo > p->max_best)
            return; /* none is left, or every axis's next plane lies past every ray's hit */
        int at = a == 0 ? k0 : a == 1 ? k1 : k2, next = at + step[a];
        float t_next = packet_next_plane(p, a, leaf, bk, base[a], &next, kend[a], step[a]);
        if (a == 0) {
            k0 = next;
            n0 = t_next;
        } else if (a == 1) {
            k1 = next;
            n1 = t_next;
        } else {
            k2 = next;
            n2 = t_next;
        }
        packet_plane(p, a, at, leaf, lo, hi, packed, table, bk, base[a], objects, leaf_units, &pb);
    }
}

/* A subtree to visit: its node and box, and where the tile's rays can be inside its parent's
 * box and its ancestors' fills (occupancy.h; packet_box_open's interval before the widening),
 * so that only the split axis's slab is new to it. */
typedef struct packet_frame {
    uint32_t node;
    int axis;         /* the parent's split axis; 3 at the root (all three slabs are new) */
    float t0, t1;
    float lo[3], hi[3];
} packet_frame;

#define PACKET_STACK 128

/* A subtree's fill (occupancy.h) is tested where it leaves out at least a quarter of its box's
 * height: a wider one rarely turns a tile away. Testing every partial fill cost views at
 * street level or in the terrain 2.6-3.0 % more instructions, this 1.4-2.2 %, for the same
 * gains (docs/performance.md, "Subtrees' heights"). */
#define FILL_NARROW 192

/* Frame *d for child `node` of a node with box [lo, hi] split on axis a, its extent on that
 * axis [la, ha], the node's interval [t0, t1]. */
static inline void packet_frame_put(packet_frame *d, uint32_t node, uint32_t a, float t0, float t1, const float *lo,
                                    const float *hi, float la, float ha)
{
    d->node = node;
    d->axis = (int)a;
    d->t0 = t0;
    d->t1 = t1;
    for (int b = 0; b < 3; ++b) {
        d->lo[b] = lo[b];
        d->hi[b] = hi[b];
    }
    d->lo[a] = la;
    d->hi[a] = ha;
}

/* Whether the tile's interval [t0, t1] in a box, widened by the slack, is not empty and starts
 * no farther than the farthest best hit. */
PK_INLINE int packet_interval_open(const packet *p, float t0, float t1)
{
    float w0 = t0 - t0 * T_SLACK;
    return w0 <= t1 + fabsf(t1) * T_SLACK && w0 <= p->max_best + p->max_best * T_SLACK;
}

/* packet_box_open for a frame: the parent's interval narrowed by the one slab that differs
 * (the child's box is its parent's cut at the split). The same values as all three slabs
 * anew, narrowed by the ancestors' fills: the unchanged two give what they gave the parent,
 * and a slab cut shorter gives an entry no nearer and an exit no farther (each bound is
 * monotone in the plane's offset, as rounding is), so the maximum of the entries and the
 * minimum of the exits are unchanged by the parent's wider one. Leaves [*t0, *t1] as the
 * frame's interval; 0 where no ray may have a better hit inside the box. */
PK_INLINE int packet_frame_open(const packet *p, const packet_frame *f, float *t0, float *t1)
{
    *t0 = f->t0;
    *t1 = f->t1;
    for (int a = f->axis == 3 ? 0 : f->axis, e = f->axis == 3 ? 3 : f->axis + 1; a < e; ++a)
        if (!packet_slab(p, a, f->lo[a], f->hi[a], t0, t1))
            return 0;
    return packet_interval_open(p, *t0, *t1);
}

PK_INLINE void packet_traverse(packet *p, const vis_scene_view *view, const vis_node_fill *fill)
{
    packet_frame stack[PACKET_STACK];
    int sp = 0;
    stack[0].node = 0;
    stack[0].axis = 3;
    stack[0].t0 = p->t_near;
    stack[0].t1 = p->t_far;
    for (int a = 0; a < 3; ++a) {
        stack[0].lo[a] = 0.0f;
        stack[0].hi[a] = view->size[a];
    }
    sp = vis_node_filled(fill[0]); /* only subtrees that hold a primitive are pushed */
    while (sp > 0 && !p->given_up) {
        /* The frame is opened where it lies, and its slot then takes a child: the far one,
         * or the near one alone. */
        packet_frame *f = &stack[--sp];
        float t0, t1;
        if (!packet_frame_open(p, f, &t0, &t1))
            continue;
        p->nodes += (uint32_t)p->counting;
        uint32_t info = view->nodes[f->node].info;
        if ((info & 3u) == VIS_NODE_LEAF) {
            packet_leaf(p, view, &view->leaves[info >> 2]);
            continue;
        }
        /* Where on y the subtree's primitives lie inside the box: its slab narrows the
         * interval the children start from (what lies outside it holds nothing of theirs).
         * Only for a fill narrower than FILL_NARROW 255ths of the box's height. */
        vis_node_fill nf = fill[f->node];
        if (nf.hi - nf.lo < FILL_NARROW &&
            (!packet_slab(p, 1, vis_node_fill_lo(nf, f->lo[1], f->hi[1]), vis_node_fill_hi(nf, f->lo[1], f->hi[1]),
                         &t0, &t1) ||
             !packet_interval_open(p, t0, t1)))
            continue;
        uint32_t a = info & 3u, first = info >> 2;
        float split = view->nodes[f->node].split;
        /* The child on the eye's side first (any order is correct; this one finds the
         * nearest hits first, so the far side is often skipped): it is pushed last. */
        uint32_t near_child = p->o[a] < split || (p->o[a] == split && p->sign[a] < 0) ? first : first + 1u;
        uint32_t far_child = near_child ^ first ^ (first + 1u);
        int far_in = vis_node_filled(fill[far_child]), near_in = vis_node_filled(fill[near_child]);
        if (!(far_in | near_in))
            continue;
        if (sp + 2 > PACKET_STACK)
            continue; /* cannot happen: depth is far below the stack size */
        /* The children are written field by field from the node's box read once: a copy of
         * a frame just written would read it back before its stores have landed. Child
         * `first` is the box below the split, `first + 1` the box above it. */
        float lo[3] = {f->lo[0], f->lo[1], f->lo[2]}, hi[3] = {f->hi[0], f->hi[1], f->hi[2]};
        uint32_t one = far_in ? far_child : near_child;
        packet_frame_put(&stack[sp++], one, a, t0, t1, lo, hi, one == first ? lo[a] : split, one == first ? split : hi[a]);
        if (far_in & near_in)
            packet_frame_put(&stack[sp++], near_child, a, t0, t1, lo, hi, near_child == first ? lo[a] : split,
                             near_child == first ? split : hi[a]);
    }
}

#ifndef PK_EFFECTS
/* The object IDs and depths of a tile wholly inside an image `width` wide, row by row: each
 * row of a unit is UNIT_W lanes in a row of pixels, copied together (the lane-by-lane loop
 * below, with its per-lane pixel, edge and mode tests, cost a fifth of a near view). */
PK_INLINE void packet_store_rows(const packet *p, uint32_t width, uint32_t x0, uint32_t y0, uint32_t *ids,
                                 float *depth)
{
#if defined(PK_VECTORS) && UNIT_W == 4
    /* A unit at a time: its two rows of 4 lanes, masked in one vector. */
    for (int r = 0; r < UNITS; ++r) {
        pk_v8i obj, id;
        memcpy(&obj, &p->best_obj[r * UNIT], sizeof obj);
        memcpy(&id, &p->best_id[r * UNIT], sizeof id);
        id &= obj != (pk_v8i){-1, -1, -1, -1, -1, -1, -1, -1}; /* VIS_NO_OBJECT: ID 0 */
        size_t at = (size_t)(y0 + lane_y(r * UNIT)) * width + x0 + lane_x(r * UNIT);
        memcpy(ids + at, &id, 4 * sizeof(uint32_t));
        memcpy(ids + at + width, (const uint32_t *)&id + 4, 4 * sizeof(uint32_t));
        if (depth) {
            memcpy(depth + at, &p->best_t[r * UNIT], 4 * sizeof(float));
            memcpy(depth + at + width, &p->best_t[r * UNIT + 4], 4 * sizeof(float));
        }
    }
    return;
#endif
    for (int ty = 0; ty < PK_TILE_H; ++ty) {
        uint32_t *out = ids + (size_t)(y0 + (uint32_t)ty) * width + x0;
        int i0 = ty / (UNIT / UNIT_W) * (PK_TILE_W / UNIT_W) * UNIT + ty % (UNIT / UNIT_W) * UNIT_W;
        for (int uc = 0; uc < PK_TILE_W / UNIT_W; ++uc)
            for (int j = 0; j < UNIT_W; ++j) {
                int i = i0 + uc * UNIT + j;
                uint32_t hit = p->best_obj[i] != VIS_NO_OBJECT; /* a mask, not a branch: vectorised */
                out[uc * UNIT_W + j] = p->best_id[i] & (0u - hit);
            }
    }
    if (!depth)
        return;
    for (int ty = 0; ty < PK_TILE_H; ++ty) {
        float *out = depth + (size_t)(y0 + (uint32_t)ty) * width + x0;
        int i0 = ty / (UNIT / UNIT_W) * (PK_TILE_W / UNIT_W) * UNIT + ty % (UNIT / UNIT_W) * UNIT_W;
        for (int uc = 0; uc < PK_TILE_W / UNIT_W; ++uc)
            memcpy(out + uc * UNIT_W, &p->best_t[i0 + uc * UNIT], UNIT_W * sizeof(float));
    }
}

int PK_ENTRY(const vis_ray_setup *setup, const vis_scene_view *view, const vis_node_fill *fill, float give_up_t,
             int max_leaves, uint32_t x0, uint32_t y0, uint32_t *ids, float *depth, uint32_t *cost);

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(VIS_NO_TARGET_CLONES)
__attribute__((target_clones("avx2", "default")))
#endif
int PK_ENTRY(const vis_ray_setup *setup, const vis_scene_view *view, const vis_node_fill *fill, float give_up_t,
             int max_leaves, uint32_t x0, uint32_t y0, uint32_t *ids, float *depth, uint32_t *cost)
{
    packet p;
    packet_rays(&p, setup, x0, y0);
    p.give_up_t = give_up_t;
    p.max_leaves = max_leaves;
    p.counting = cost != NULL;
    if (p.counting)
        memset(p.tests, 0, sizeof p.tests);
    packet_bounds(&p);
    packet_traverse(&p, view, fill);
    if (p.given_up)
        return 0;
    if (x0 + PK_TILE_W <= setup->width && y0 + PK_TILE_H <= setup->height && setup->id_mode != 1u && !cost) {
        packet_store_rows(&p, setup->width, x0, y0, ids, depth);
        return 1;
    }
    for (int i = 0; i < LANES; ++i) {
        uint32_t x = x0 + lane_x(i), y = y0 + lane_y(i);
        if (x >= setup->width || y >= setup->height)
            continue;
        size_t at = (size_t)y * setup->width + x;
        uint32_t id = 0u;
        if (p.best_obj[i] != VIS_NO_OBJECT) {
            id = p.best_id[i];
            if (setup->id_mode == 1u) {
                vis_ray r;
                vis_hit h;
                packet_lane(&p, i, &r, &h);
                id = vis_hit_leaf_id(&r, &h, VIS_SCENE_VIEW_ARGS(view));
            }
        }
        ids[at] = id;
        if (depth)
            depth[at] = p.best_t[i];
        if (cost)
            cost[at] = p.nodes + p.tests[i];
    }
    return 1;
}
#else /* PK_EFFECTS */

/* The tile's primary rays by packet, then each pixel by vis_effects_finish (its secondary rays
 * alone, by the stack method), written to `out` as vis_cpu_effects_tile does; *secondary gets
 * the secondary rays cast added. Returns 0, having written nothing, where the packet gives up
 * (packet.c): its rays then go one by one. */
int PK_ENTRY(const vis_ray_setup *setup, const vis_scene_view *view, const vis_node_fill *fill, float give_up_t,
             uint32_t x0, uint32_t y0, const vis_effect_setup *effects, const vis_effect_outputs *out,
             uint64_t *secondary);

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(VIS_NO_TARGET_CLONES)
__attribute__((target_clones("avx2", "default")))
#endif
int PK_ENTRY(const vis_ray_setup *setup, const vis_scene_view *view, const vis_node_fill *fill, float give_up_t,
             uint32_t x0, uint32_t y0, const vis_effect_setup *effects, const vis_effect_outputs *out,
             uint64_t *secondary)
{
    packet p;
    packet_rays(&p, setup, x0, y0);
    p.give_up_t = give_up_t;
    p.see_through = (effects->effects & VIS_FX_SEE_THROUGH) != 0u;
    for (int i = 0; i < LANES; ++i) {
        p.best_prim[i] = 0u;
        p.best_plane[i] = 0.0f;
    }
    if (p.see_through)
        for (int i = 0; i < LANES; ++i)
            vis_hit_init(&p.fx[i], VIS_ST_RECORD, effects->layers, VIS_NO_AXIS, 0.0f);
    packet_bounds(&p);
    packet_traverse(&p, view, fill);
    if (p.given_up)
        return 0;
    uint64_t cast = 0;
    for (int i = 0; i < LANES; ++i) {
        uint32_t x = x0 + lane_x(i), y = y0 + lane_y(i);
        if (x >= setup->width || y >= setup->height)
            continue;
        vis_ray r;
        vis_hit h;
        packet_lane(&p, i, &r, &h);
        vis_effect_pixel px;
        vis_effects_finish(setup, effects, effects->effects, VIS_TRAVERSAL_ID_PACKET, &r, &h, VIS_SCENE_VIEW_ARGS(view),
                           &px);
        vis_effect_pixel_store(out, effects->layers, (size_t)y * setup->width + x, &px);
        cast += px.secondary;
    }
    *secondary += cast;
    return 1;
}
#endif /* PK_EFFECTS */
