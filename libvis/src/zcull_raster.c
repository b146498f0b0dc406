/*
 * zcull_raster.c — the z-buffer culler's rasteriser: triangle/polygon setup, tiled traversal
 * with half-plane edge functions, the homogeneous clipper, and the box tests.
 *
 * Sources:
 *  - Half-plane edge functions E(x,y) = (x-x0)*Ay - (y-y0)*Ax evaluated incrementally:
 *    Pineda, "A Parallel Algorithm for Polygon Rasterization", SIGGRAPH 1988.
 *  - Tiled traversal (whole tiles accepted or rejected from their corner values, the inner
 *    loop only for tiles an edge crosses; tile-major memory for locality):
 *    McCormack & McNamara, "Tiled Polygon Traversal Using Half-Plane Edge Functions",
 *    Graphics Hardware 2000; Chun et al., tile-traversal scan conversion (seeds/003).
 *  - Fixed-point vertices, the top-left fill rule, and the guard band (clip against x/y only
 *    when the fixed-point range would overflow): the D3D10 rasterisation rules; F. Giesen,
 *    "The barycentric conspiracy" / "Optimizing the basic rasterizer" (2013).
 *  - Homogeneous clipping: Sutherland & Hodgman 1974; Blinn & Newell, "Clipping using
 *    homogeneous coordinates", SIGGRAPH 1978.
 *  - Conservative occluder depth and a per-tile farthest depth tested before pixels:
 *    Greene, Kass & Miller, "Hierarchical Z-Buffer Visibility", SIGGRAPH 1993; Hasselgren,
 *    Andersson & Akenine-Moeller, "Masked Software Occlusion Culling", HPG 2016 (runtime ISA
 *    choice, conservative results).
 *
 * Exactness. Edge functions are exact integers: setup in int64, and inside a tile an edge
 * that crosses the tile fits int32 (|value| <= 7*(|A|+|B|) < 2^31 because k + f <= 26).
 * Sampling only pixel centres lets the 2^f factor be divided out exactly (see edge_setup),
 * so the inner loop steps by the raw vertex deltas. Depth is evaluated in float in one fixed
 * order, d = (dT + row[j]) + lane[i], by every ISA, so all paths are bit-identical.
 *
 * Conservativeness (the culler must never hide what the ray pass would see):
 *  - coverage: every boundary edge is shrunk by a bound on how far snapping and double
 *    rounding moved it, so a covered pixel centre is inside the exact projected polygon;
 *  - depth: the 1/w plane is lowered by a bound on its fitting and float-evaluation error,
 *    or replaced by the polygon's farthest vertex depth when the plane is ill-conditioned;
 *  - boxes: the nearest depth is rounded up, and the pixel rectangle is rounded outwards.
 */
#include "zcull.h"

#include <float.h>
#include <math.h>
#include <string.h>

#if defined(__x86_64__) || defined(_M_X64) || defined(__i386__)
#  define ZC_X86 1
#  include <emmintrin.h>
#  if defined(__GNUC__)
#    define ZC_HAVE_AVX2 1
#    include <immintrin.h>
#  endif
#endif

#define ZC_MAXE VIS_ZC_MAX_VERTS

/* ---- ISA selection ------------------------------------------------------------------- */

vis_zc_simd vis_zc_simd_resolve(vis_zc_simd wanted)
{
#if defined(ZC_X86)
    int avx2 = 0;
#  if defined(ZC_HAVE_AVX2)
    __builtin_cpu_init();
    avx2 = __builtin_cpu_supports("avx2") ? 1 : 0;
#  endif
    if (wanted == VIS_ZC_SIMD_SCALAR || wanted == VIS_ZC_SIMD_SSE2)
        return wanted;
    return avx2 ? VIS_ZC_SIMD_AVX2 : VIS_ZC_SIMD_SSE2;
#else
    (void)wanted;
    return VIS_ZC_SIMD_SCALAR;
#endif
}

const char *vis_zc_simd_name(vis_zc_simd simd)
{
    switch (simd) {
    case VIS_ZC_SIMD_SCALAR: return "scalar";
    case VIS_ZC_SIMD_SSE2: return "sse2";
    case VIS_ZC_SIMD_AVX2: return "avx2";
    default: return "auto";
    }
}

/* ---- target -------------------------------------------------------------------------- */

void vis_zc_target_sizes(uint32_t width, uint32_t height, size_t *depth_floats, size_t *tile_floats)
{
    size_t tx = (width + 7u) / 8u, ty = (height + 7u) / 8u;
    if (depth_floats)
        *depth_floats = tx * ty * VIS_ZC_TILE_PIXELS;
    if (tile_floats)
        *tile_floats = tx * ty;
}

void vis_zc_target_init(vis_zc_target *t, uint32_t width, uint32_t height, float *depth, float *tile_min,
                        uint32_t *count, vis_zc_simd simd)
{
    memset(t, 0, sizeof *t);
    t->width = width;
    t->height = height;
    t->tiles_x = (width + 7u) / 8u;
    t->tiles_y = (height + 7u) / 8u;
    /* Guard band +-2^k with 2^k >= 2*max(W,H): a full screen of guard on every side. The
     * in-tile int32 bound needs k + f <= 26; take as many sub-pixel bits as fit, up to 16
     * (512x512: k = 10, f = 16; 16384: k = 15, f = 11; always >= 8). */
    uint32_t s = width > height ? width : height;
    int k = 1;
    while ((1u << k) < 2u * s)
        k++;
    t->guard_bits = k;
    t->sub_bits = 26 - k < 16 ? 26 - k : 16;
    t->depth = depth;
    t->tile_min = tile_min;
    t->count = count;
    t->simd = vis_zc_simd_resolve(simd);
}

void vis_zc_target_clear(vis_zc_target *t)
{
    size_t ntiles = (size_t)t->tiles_x * t->tiles_y;
    memset(t->depth, 0, ntiles * VIS_ZC_TILE_PIXELS * sizeof(float));
    memset(t->tile_min, 0, ntiles * sizeof(float));
    if (t->count)
        memset(t->count, 0, ntiles * VIS_ZC_TILE_PIXELS * sizeof(uint32_t));
    /* Pixels past the right and bottom edges: "infinitely near", so that a tile's farthest
     * depth is that of its real pixels alone, and no occluder write can change them. */
    uint32_t xr = t->width & 7u, yr = t->height & 7u;
    for (uint32_t ty = 0; ty < t->tiles_y; ty++) {
        for (uint32_t tx = 0; tx < t->tiles_x; tx++) {
            int right = xr && tx == t->tiles_x - 1, bottom = yr && ty == t->tiles_y - 1;
            if (!right && !bottom)
                continue;
            float *d = t->depth + ((size_t)ty * t->tiles_x + tx) * VIS_ZC_TILE_PIXELS;
            for (uint32_t j = 0; j < 8; j++)
                for (uint32_t i = 0; i < 8; i++)
                    if ((right && i >= xr) || (bottom && j >= yr))
                        d[j * 8 + i] = FLT_MAX;
        }
    }
    t->polygons = 0;
    t->tiles = 0;
}

/* ---- the per-tile kernels ------------------------------------------------------------ */

/* One tile's work. Edge k of the nc crossing edges has value e[k] + b[k]*j + a[k]*i at
 * pixel (i, j) of the tile; a pixel is covered when all are >= 0. */
typedef struct zc_tile_job {
    float *depth;          /* the tile's 64 depths                                        */
    uint32_t *count;       /* the tile's 64 counts, or NULL                                */
    const float *lane;     /* lane[i] = za*i (float)                                       */
    const float *row;      /* row[j] = zb*j (float)                                        */
    float dt;              /* depth at the tile's first pixel                               */
    int nc;
    int32_t e[ZC_MAXE], a[ZC_MAXE], b[ZC_MAXE];
} zc_tile_job;

/* Returns the tile's farthest depth after the write (depth mode). */
typedef float (*zc_tile_fn)(const zc_tile_job *job);

static float zc_tile_scalar(const zc_tile_job *jb)
{
    float mn = FLT_MAX;
    for (int j = 0; j < 8; j++) {
        float dr = jb->dt + jb->row[j];
        for (int i = 0; i < 8; i++) {
            int32_t m = 0;
            for (int k = 0; k < jb->nc; k++)
                m |= (jb->e[k] + jb->b[k] * j) + jb->a[k] * i;
            int p = j * 8 + i;
            if (jb->count) {
                jb->count[p] += m >= 0;
                continue;
            }
            float o = jb->depth[p];
            if (m >= 0) {
                float d = dr + jb->lane[i];
                o = d > o ? d : o;
                jb->depth[p] = o;
            }
            mn = o < mn ? o : mn;
        }
    }
    return mn;
}

#if defined(ZC_X86)
static float zc_tile_sse2(const zc_tile_job *jb)
{
    __m128 lane0 = _mm_loadu_ps(jb->lane), lane1 = _mm_loadu_ps(jb->lane + 4);
    __m128i ea0[ZC_MAXE], ea1[ZC_MAXE];
    for (int k = 0; k < jb->nc; k++) {
        int32_t a = jb->a[k];
        ea0[k] = _mm_setr_epi32(0, a, 2 * a, 3 * a);
        ea1[k] = _mm_setr_epi32(4 * a, 5 * a, 6 * a, 7 * a);
    }
    __m128 mn = _mm_set1_ps(FLT_MAX);
    __m128i one = _mm_set1_epi32(1);
    for (int j = 0; j < 8; j++) {
        __m128i m0 = _mm_setzero_si128(), m1 = _mm_setzero_si128();
        for (int k = 0; k < jb->nc; k++) {
            __m128i er = _mm_set1_epi32(jb->e[k] + jb->b[k] * j);
            m0 = _mm_or_si128(m0, _mm_add_epi32(er, ea0[k]));
            m1 = _mm_or_si128(m1, _mm_add_epi32(er, ea1[k]));
        }
        m0 = _mm_srai_epi32(m0, 31); /* -1 outside, 0 inside */
        m1 = _mm_srai_epi32(m1, 31);
        if (jb->count) {
            __m128i *c = (__m128i *)(jb->count + j * 8);
            _mm_storeu_si128(c, _mm_add_epi32(_mm_loadu_si128(c), _mm_add_epi32(one, m0)));
            _mm_storeu_si128(c + 1, _mm_add_epi32(_mm_loadu_si128(c + 1), _mm_add_epi32(one, m1)));
            continue;
        }
        float *dp = jb->depth + j * 8;
        __m128 dr = _mm_set1_ps(jb->dt + jb->row[j]);
        __m128 o0 = _mm_loadu_ps(dp), o1 = _mm_loadu_ps(dp + 4);
        __m128 n0 = _mm_max_ps(_mm_add_ps(dr, lane0), o0);
        __m128 n1 = _mm_max_ps(_mm_add_ps(dr, lane1), o1);
        __m128 k0 = _mm_castsi128_ps(m0), k1 = _mm_castsi128_ps(m1);
        n0 = _mm_or_ps(_mm_and_ps(k0, o0), _mm_andnot_ps(k0, n0));
        n1 = _mm_or_ps(_mm_and_ps(k1, o1), _mm_andnot_ps(k1, n1));
        _mm_storeu_ps(dp, n0);
        _mm_storeu_ps(dp + 4, n1);
        mn = _mm_min_ps(mn, _mm_min_ps(n0, n1));
    }
    mn = _mm_min_ps(mn, _mm_shuffle_ps(mn, mn, _MM_SHUFFLE(1, 0, 3, 2)));
    mn = _mm_min_ps(mn, _mm_shuffle_ps(mn, mn, _MM_SHUFFLE(2, 3, 0, 1)));
    return _mm_cvtss_f32(mn);
}
#endif

#if defined(ZC_HAVE_AVX2)
__attribute__((target("avx2"))) static float zc_tile_avx2(const zc_tile_job *jb)
{
    const __m256 lane = _mm256_loadu_ps(jb->lane);
    const __m256i iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const int nc = jb->nc;
    /* edge values of the current row, stepped by b per row: exact integer adds */
    __m256i ev[ZC_MAXE], eb[ZC_MAXE];
    for (int k = 0; k < nc; k++) {
        ev[k] = _mm256_add_epi32(_mm256_set1_epi32(jb->e[k]), _mm256_mullo_epi32(_mm256_set1_epi32(jb->a[k]), iota));
        eb[k] = _mm256_set1_epi32(jb->b[k]);
    }
    if (jb->count) {
        const __m256i one = _mm256_set1_epi32(1);
        for (int j = 0; j < 8; j++) {
            __m256i m = _mm256_setzero_si256();
            for (int k = 0; k < nc; k++) {
                m = _mm256_or_si256(m, ev[k]);
                ev[k] = _mm256_add_epi32(ev[k], eb[k]);
            }
            __m256i *c = (__m256i *)(jb->count + j * 8);
            _mm256_storeu_si256(c, _mm256_add_epi32(_mm256_loadu_si256(c), _mm256_add_epi32(one, _mm256_srai_epi32(m, 31))));
        }
        return 0.0f;
    }
    __m256 mn = _mm256_set1_ps(FLT_MAX);
    for (int j = 0; j < 8; j++) {
        __m256i m = _mm256_setzero_si256();
        for (int k = 0; k < nc; k++) {
            m = _mm256_or_si256(m, ev[k]);
            ev[k] = _mm256_add_epi32(ev[k], eb[k]);
        }
        float *dp = jb->depth + j * 8;
        __m256 o = _mm256_loadu_ps(dp);
        __m256 d = _mm256_add_ps(_mm256_set1_ps(jb->dt + jb->row[j]), lane);
        __m256 n = _mm256_blendv_ps(_mm256_max_ps(d, o), o, _mm256_castsi256_ps(m));
        _mm256_storeu_ps(dp, n);
        mn = _mm256_min_ps(mn, n);
    }
    __m128 h = _mm_min_ps(_mm256_castps256_ps128(mn), _mm256_extractf128_ps(mn, 1));
    h = _mm_min_ps(h, _mm_shuffle_ps(h, h, _MM_SHUFFLE(1, 0, 3, 2)));
    h = _mm_min_ps(h, _mm_shuffle_ps(h, h, _MM_SHUFFLE(2, 3, 0, 1)));
    return _mm_cvtss_f32(h);
}
#endif

static zc_tile_fn zc_tile_kernel(vis_zc_simd simd)
{
#if defined(ZC_HAVE_AVX2)
    if (simd == VIS_ZC_SIMD_AVX2)
        return zc_tile_avx2;
#endif
#if defined(ZC_X86)
    if (simd == VIS_ZC_SIMD_SSE2)
        return zc_tile_sse2;
#endif
    (void)simd;
    return zc_tile_scalar;
}

/* ---- setup and traversal ------------------------------------------------------------- */

/* Plain comparisons: fmin/fmax/ldexp/ceil are library calls without fast-math, and NaN
 * never reaches these (inputs are finite by construction). fabs is a builtin (a mask). */
static inline double zc_maxd(double a, double b) { return a > b ? a : b; }
static inline double zc_mind(double a, double b) { return a < b ? a : b; }
static inline double zc_absd(double a) { return fabs(a); }

/* Round to nearest (ties to even) for |x| <= 2^51, as nearbyint does in the default
 * rounding mode, without the library call: the sum is rounded in double (SSE2, no excess
 * precision), and without -ffast-math no compiler folds (x + c) - c to x. */
static inline double zc_round(double x)
{
    const double magic = 0x1.8p52;
    double y = x + magic;
    return y - magic;
}

/* floor(v / 2^s) for any sign (>> on negative values is implementation-defined in C). */
static inline int64_t zc_floor_shift(int64_t v, int s)
{
    return v >= 0 ? v >> s : -((-v - 1) >> s) - 1;
}

typedef struct zc_setup {
    int n;
    int64_t a[ZC_MAXE], b[ZC_MAXE], c[ZC_MAXE]; /* e(X,Y) = a*X + b*Y + c at pixel (X,Y)    */
    int32_t x0, y0, x1, y1;                      /* covered pixel range (inclusive)          */
    double zx, zy, z0;                           /* depth = z0 + zx*X + zy*Y at pixel (X,Y)   */
} zc_setup;

/* Orientation, bounds and edge equations of a fixed-point polygon. margin (may be NULL)
 * gives each edge's shrink; eps >= 0 instead derives the shrinks from a per-coordinate
 * vertex error bound of eps sub-pixels. Returns 0 when no pixel centre can be covered. */
static int zc_setup_edges(const vis_zc_target *t, int n, const int64_t *xin, const int64_t *yin,
                          const int64_t *margin_in, double eps, zc_setup *s)
{
    const int f = t->sub_bits;
    const int64_t half = (int64_t)1 << (f - 1);
    const int64_t *x = xin, *y = yin;
    int64_t minx = x[0], maxx = x[0], miny = y[0], maxy = y[0];
    for (int i = 1; i < n; i++) {
        minx = x[i] < minx ? x[i] : minx;
        maxx = x[i] > maxx ? x[i] : maxx;
        miny = y[i] < miny ? y[i] : miny;
        maxy = y[i] > maxy ? y[i] : maxy;
    }
    /* Pixel centres (X*2^f + half) inside [min, max]. */
    int64_t X0 = -zc_floor_shift(half - minx, f), X1 = zc_floor_shift(maxx - half, f);
    int64_t Y0 = -zc_floor_shift(half - miny, f), Y1 = zc_floor_shift(maxy - half, f);
    if (X0 < 0) X0 = 0;
    if (Y0 < 0) Y0 = 0;
    if (X1 > (int64_t)t->width - 1) X1 = (int64_t)t->width - 1;
    if (Y1 > (int64_t)t->height - 1) Y1 = (int64_t)t->height - 1;
    if (X0 > X1 || Y0 > Y1)
        return 0;
    int64_t area2 = 0;
    for (int i = 0; i < n; i++) {
        int j = i + 1 == n ? 0 : i + 1;
        area2 += x[i] * y[j] - x[j] * y[i];
    }
    if (area2 == 0)
        return 0;
    /* Wound the other way, every edge function is negated (same lines, inside flipped). */
    const int64_t sgn = area2 > 0 ? 1 : -1;
    s->n = n;
    s->x0 = (int32_t)X0;
    s->y0 = (int32_t)Y0;
    s->x1 = (int32_t)X1;
    s->y1 = (int32_t)Y1;
    /* The shrink, in edge-function units: for p a pixel centre, v_i a snapped vertex and
     * e the vertex errors (|e| <= eps per coordinate, d = e_j - e_i),
     *   E_exact(p) - E_snapped(p) = cross(d, p - v_i) - cross(D + d, e_i),
     * bounded by 2 eps (|p-v_i|_x + |p-v_i|_y) + eps (|Dx| + |Dy|) + 4 eps^2. Traversal
     * touches whole tiles, so p ranges over the tiles around the bounds: one bound, from the
     * tile-aligned extent, holds for every edge. */
    int64_t m = 0;
    if (eps >= 0) {
        double ext = (double)(((((X1 | 7) - (X0 & ~(int64_t)7)) + ((Y1 | 7) - (Y0 & ~(int64_t)7)) + 2) << f));
        double bb = (double)((maxx - minx) + (maxy - miny));
        m = (int64_t)(eps * (2.0 * ext + bb) + 4.0 * eps * eps) + 2; /* >= ceil(bound) + 1 */
    }
    for (int i = 0; i < n; i++) {
        int j = i + 1 == n ? 0 : i + 1;
        int64_t dx = sgn * (x[j] - x[i]), dy = sgn * (y[j] - y[i]);
        if (margin_in)
            m = margin_in[i];
        /* Top-left rule (y down, edges wound with the inside on their left): a top edge
         * runs right (dy == 0, dx > 0), a left edge runs up (dy < 0). Others exclude E == 0.
         * Reversed, an edge runs from v_j to v_i, but v_i still lies on its line. */
        int tl = dy < 0 || (dy == 0 && dx > 0);
        /* E(p) = dx*(py - y_i) - dy*(px - x_i) at p = (X*2^f + half, Y*2^f + half)
         *      = 2^f*(dx*Y - dy*X) + K.  E - m - !tl >= 0  <=>  dx*Y - dy*X + floor((K - m - !tl)/2^f) >= 0
         * because the left part is an integer: exact, with the 2^f factor gone. */
        int64_t K = dx * (half - y[i]) - dy * (half - x[i]);
        s->a[i] = -dy;
        s->b[i] = dx;
        s->c[i] = zc_floor_shift(K - m - (tl ? 0 : 1), f);
    }
    return 1;
}

/* Depth at a tile's first pixel, lowered by a bound on the float evaluation error of every
 * pixel of the tile: each rounding (dT, za, zb, row, lane and the two sums) is within 2^-24
 * of |dT| + 7(|za| + |zb|); 2^-21 covers them all. */
static inline float zc_tile_dt(const zc_setup *s, double zgrad8, int tx, int ty)
{
    double pt = s->z0 + s->zx * (double)(tx * 8) + s->zy * (double)(ty * 8);
    return (float)(pt - (zc_absd(pt) + zgrad8) * 0x1p-21);
}

static void zc_traverse(vis_zc_target *t, const zc_setup *s)
{
    const int n = s->n;
    const int depth_mode = t->count == NULL;
    zc_tile_fn kernel = zc_tile_kernel(t->simd);
    zc_tile_job job;
    float lane[8], row[8];
    float za = (float)s->zx, zb = (float)s->zy;
    float lane_max = 0.0f, row_max = 0.0f;
#if defined(ZC_X86)
    {
        const __m128 i0 = _mm_setr_ps(0, 1, 2, 3), i1 = _mm_setr_ps(4, 5, 6, 7);
        const __m128 va = _mm_set1_ps(za), vb = _mm_set1_ps(zb);
        _mm_storeu_ps(lane, _mm_mul_ps(va, i0));
        _mm_storeu_ps(lane + 4, _mm_mul_ps(va, i1));
        _mm_storeu_ps(row, _mm_mul_ps(vb, i0));
        _mm_storeu_ps(row + 4, _mm_mul_ps(vb, i1));
    }
#else
    for (int i = 0; i < 8; i++) {
        lane[i] = za * (float)i;
        row[i] = zb * (float)i;
    }
#endif
    /* the products are monotonic in i: the largest is at one end */
    lane_max = lane[7] > 0.0f ? lane[7] : 0.0f;
    row_max = row[7] > 0.0f ? row[7] : 0.0f;
    const double zgrad8 = 8.0 * (zc_absd(s->zx) + zc_absd(s->zy));
    job.lane = lane;
    job.row = row;
    job.count = NULL;

    int64_t lo[ZC_MAXE], hi[ZC_MAXE], erow[ZC_MAXE], e[ZC_MAXE];
    const int tx0 = s->x0 >> 3, tx1 = s->x1 >> 3, ty0 = s->y0 >> 3, ty1 = s->y1 >> 3;
    for (int k = 0; k < n; k++) {
        int64_t a = s->a[k], b = s->b[k];
        lo[k] = (a < 0 ? a * 7 : 0) + (b < 0 ? b * 7 : 0);
        hi[k] = (a > 0 ? a * 7 : 0) + (b > 0 ? b * 7 : 0);
        erow[k] = a * (int64_t)(tx0 * 8) + b * (int64_t)(ty0 * 8) + s->c[k];
    }
    if (depth_mode && (tx1 - tx0 + 1) * (ty1 - ty0 + 1) > 2) {
        /* The whole polygon first: its largest stored depth is that of a corner tile (the
         * tile depth is monotonic in the affine plane; a rounding exception could only skip
         * a write, which is conservative). Hidden everywhere: done. */
        float dm = zc_tile_dt(s, zgrad8, tx0, ty0);
        float d1 = zc_tile_dt(s, zgrad8, tx1, ty0), d2 = zc_tile_dt(s, zgrad8, tx0, ty1);
        float d3 = zc_tile_dt(s, zgrad8, tx1, ty1);
        dm = d1 > dm ? d1 : dm;
        dm = d2 > dm ? d2 : dm;
        dm = d3 > dm ? d3 : dm;
        dm = (dm + row_max) + lane_max;
        int hidden = 1;
        for (int ty = ty0; ty <= ty1 && hidden; ty++) {
            const float *tm = t->tile_min + (size_t)ty * t->tiles_x;
            for (int tx = tx0; tx <= tx1; tx++)
                if (dm > tm[tx]) {
                    hidden = 0;
                    break;
                }
        }
        if (hidden)
            return;
    }
    t->polygons++;
    for (int ty = ty0; ty <= ty1; ty++) {
        size_t ti = (size_t)ty * t->tiles_x + (size_t)tx0;
        for (int k = 0; k < n; k++)
            e[k] = erow[k];
        for (int tx = tx0; tx <= tx1; tx++, ti++) {
            float dt = 0.0f;
            if (depth_mode) {
                dt = zc_tile_dt(s, zgrad8, tx, ty);
                /* Rounded addition is monotonic, so this bounds every value the kernel
                 * computes: skip tiles already nearer everywhere (hierarchical test). */
                if (!((dt + row_max) + lane_max > t->tile_min[ti]))
                    goto next;
            }
            int nc = 0;
            for (int k = 0; k < n; k++) {
                if (e[k] + hi[k] < 0)
                    goto next;
                if (e[k] + lo[k] < 0) {
                    job.e[nc] = (int32_t)e[k];
                    job.a[nc] = (int32_t)s->a[k];
                    job.b[nc] = (int32_t)s->b[k];
                    nc++;
                }
            }
            job.nc = nc;
            job.dt = dt;
            job.depth = t->depth + ti * VIS_ZC_TILE_PIXELS;
            if (depth_mode) {
                t->tile_min[ti] = kernel(&job);
            } else {
                job.count = t->count + ti * VIS_ZC_TILE_PIXELS;
                kernel(&job);
                job.count = NULL;
            }
            t->tiles++;
        next:
            for (int k = 0; k < n; k++)
                e[k] += s->a[k] * 8;
        }
        for (int k = 0; k < n; k++)
            erow[k] += s->b[k] * 8;
    }
}

int vis_zc_draw_fixed(vis_zc_target *t, const vis_zc_fixed_poly *poly)
{
    if (poly->n < 3 || poly->n > VIS_ZC_MAX_VERTS)
        return 0;
    const int64_t lim = (int64_t)1 << (t->guard_bits + t->sub_bits);
    for (int i = 0; i < poly->n; i++)
        if (poly->x[i] < -lim || poly->x[i] > lim || poly->y[i] < -lim || poly->y[i] > lim || poly->margin[i] < 0)
            return 0;
    zc_setup s;
    if (!zc_setup_edges(t, poly->n, poly->x, poly->y, poly->margin, -1.0, &s))
        return 0;
    s.zx = poly->za;
    s.zy = poly->zb;
    s.z0 = poly->zc + 0.5 * poly->za + 0.5 * poly->zb;
    zc_traverse(t, &s);
    return 1;
}

/* ---- camera, clipping, projection ---------------------------------------------------- */

void vis_zc_view_make(vis_zc_view *v, const vis_zc_target *t, const double eye[3], const double f[3],
                      const double r[3], const double u[3], double tan_half_fovy, double near_dist,
                      double far_dist)
{
    /* sx = W/2 * (1 + ndc_x), ndc_x = (P.r) / (w * tan * W/H), so hx = H/(2 tan) P.r + W/2 P.f;
     * sy = H/2 * (1 - ndc_y), ndc_y = (P.u) / (w * tan), so hy = -H/(2 tan) P.u + H/2 P.f. */
    double W = (double)t->width, H = (double)t->height;
    double s = H / (2.0 * tan_half_fovy);
    double ex = 0, ey = 0, ew = 0;
    for (int a = 0; a < 3; a++) {
        v->eye[a] = eye[a];
        v->rx[a] = s * r[a] + 0.5 * W * f[a];
        v->ry[a] = -s * u[a] + 0.5 * H * f[a];
        v->rw[a] = f[a];
        ex += fabs(v->rx[a]);
        ey += fabs(v->ry[a]);
        ew += fabs(v->rw[a]);
    }
    v->near_dist = near_dist;
    v->far_dist = far_dist;
    v->guard = (double)((int64_t)1 << t->guard_bits);
    v->err_scale = ex + ey + v->guard * ew;
    v->width = W;
    v->height = H;
}

/* Homogeneous vertex: hx, hy, w. */
typedef struct zc_hv {
    double x, y, w;
} zc_hv;

/* Signed distance to clip plane `p` (>= 0 inside): 0 near, 1..4 the guard band. */
static inline double zc_plane_dist(const vis_zc_view *v, int p, zc_hv h)
{
    switch (p) {
    case 0: return h.w - v->near_dist;
    case 1: return h.x + v->guard * h.w;
    case 2: return v->guard * h.w - h.x;
    case 3: return h.y + v->guard * h.w;
    default: return v->guard * h.w - h.y;
    }
}

static int zc_clip(const vis_zc_view *v, int planes, zc_hv *poly, int n)
{
    zc_hv tmp[VIS_ZC_MAX_VERTS];
    for (int p = 0; p < 5 && n >= 3; p++) {
        if (!(planes & (1 << p)))
            continue;
        int m = 0;
        for (int i = 0; i < n; i++) {
            zc_hv a = poly[i], b = poly[i + 1 == n ? 0 : i + 1];
            double da = zc_plane_dist(v, p, a), db = zc_plane_dist(v, p, b);
            if (da >= 0)
                tmp[m++] = a;
            if ((da >= 0) != (db >= 0)) {
                /* Interpolate from the inside end so the new point is reproducible. */
                double s;
                zc_hv in = a, out = b;
                double din = da, dout = db;
                if (da < 0) {
                    in = b;
                    out = a;
                    din = db;
                    dout = da;
                }
                s = din / (din - dout);
                zc_hv c = {in.x + (out.x - in.x) * s, in.y + (out.y - in.y) * s, in.w + (out.w - in.w) * s};
                tmp[m++] = c;
            }
        }
        n = m;
        memcpy(poly, tmp, (size_t)n * sizeof *poly);
    }
    return n;
}

/* Outcode bits of a homogeneous vertex: 0 near, 1..4 guard band (the clip planes), 5..8 the
 * outermost pixel centres (left, right, top, bottom: reject-only planes). */
static inline int zc_outcode(const vis_zc_view *v, double x, double y, double w)
{
    double g = v->guard * w;
    return (w < v->near_dist) | ((x < -g) << 1) | ((x > g) << 2) | ((y < -g) << 3) | ((y > g) << 4) |
           ((x < 0.5 * w) << 5) | ((x > (v->width - 0.5) * w) << 6) | ((y < 0.5 * w) << 7) |
           ((y > (v->height - 0.5) * w) << 8);
}

/* A polygon projected and snapped: exact (double) screen positions and depths, and the
 * fixed-point vertices with the largest snapping residual (sub-pixels). */
typedef struct zc_proj {
    double sx[VIS_ZC_MAX_VERTS], sy[VIS_ZC_MAX_VERTS], iw[VIS_ZC_MAX_VERTS];
    int64_t X[VIS_ZC_MAX_VERTS], Y[VIS_ZC_MAX_VERTS];
    double res, iwmin, iwmax;
} zc_proj;

/* The one projection/snapping sequence; the AVX2 quad front end performs the same
 * operations in the same order, lane by lane, so both give the same bits. */
static void zc_project(const vis_zc_target *t, const zc_hv *h, int n, zc_proj *pr)
{
    const int f = t->sub_bits;
    const double scale = (double)((int64_t)1 << f);
    const double lim = (double)((int64_t)1 << (t->guard_bits + f));
    double res = 0.0, iwmin = INFINITY, iwmax = 0.0;
    for (int i = 0; i < n; i++) {
        double iw = 1.0 / h[i].w;
        double sx = h[i].x * iw, sy = h[i].y * iw;
        double fx = zc_mind(zc_maxd(zc_round(sx * scale), -lim), lim);
        double fy = zc_mind(zc_maxd(zc_round(sy * scale), -lim), lim);
        res = zc_maxd(res, zc_maxd(zc_absd(sx * scale - fx), zc_absd(sy * scale - fy)));
        iwmin = zc_mind(iwmin, iw);
        iwmax = zc_maxd(iwmax, iw);
        pr->iw[i] = iw;
        pr->sx[i] = sx;
        pr->sy[i] = sy;
        pr->X[i] = (int64_t)fx;
        pr->Y[i] = (int64_t)fy;
    }
    pr->res = res;
    pr->iwmin = iwmin;
    pr->iwmax = iwmax;
}

/* Sets up and draws a projected polygon whose vertices all had w >= near and lay in the
 * guard band. pmax bounds |P| of the camera-relative points it came from. */
static int zc_draw_projected(vis_zc_target *t, const vis_zc_view *v, const zc_proj *pr, int n, double pmax)
{
    const double *sx = pr->sx, *sy = pr->sy, *iw = pr->iw;
    const double iwmin = pr->iwmin, iwmax = pr->iwmax;
    if (!(iwmax > 0.0) || !(iwmax < INFINITY))
        return 0;
    /* Bound (in sub-pixels) on how far each snapped coordinate is from the exact projection:
     * the snapping residual plus the double rounding of transform, clip and divide, which is
     * a few ulps of |P| * err_scale / w (2^-44 leaves a wide margin). */
    const double scale = (double)((int64_t)1 << t->sub_bits);
    double eps = pr->res + (pmax * v->err_scale * iwmax) * 0x1p-44 * scale + 0x1p-30;
    zc_setup s;
    if (!zc_setup_edges(t, n, pr->X, pr->Y, NULL, eps, &s))
        return 0;

    /* The 1/w plane through the exact vertices (affine in screen space for a planar
     * polygon), fitted on the fan triangle of largest area. */
    int best = 1;
    double best_area = -1.0;
    for (int j = 1; j + 1 < n; j++) {
        double ar = zc_absd((sx[j] - sx[0]) * (sy[j + 1] - sy[0]) - (sx[j + 1] - sx[0]) * (sy[j] - sy[0]));
        if (ar > best_area) {
            best_area = ar;
            best = j;
        }
    }
    double x0 = sx[0], y0 = sy[0], z0 = iw[0];
    double x1 = sx[best] - x0, y1 = sy[best] - y0, z1 = iw[best] - z0;
    double x2 = sx[best + 1] - x0, y2 = sy[best + 1] - y0, z2 = iw[best + 1] - z0;
    double idet = 1.0 / (x1 * y2 - x2 * y1);
    double za = (z1 * y2 - z2 * y1) * idet;
    double zb = (x1 * z2 - x2 * z1) * idet;
    double zc = z0 - za * x0 - zb * y0;
    /* The plane's error is affine, so its largest value over the polygon is at a vertex:
     * the residuals at the vertices bound it everywhere inside. Add the double evaluation
     * error and lower the plane by both (the float evaluation error is taken per tile, in
     * zc_traverse, where it is proportional to the local depth). */
    double fit = 0.0, xm = 0.0, ym = 0.0;
    for (int i = 0; i < n; i++) {
        fit = zc_maxd(fit, zc_absd(za * sx[i] + zb * sy[i] + zc - iw[i]));
        xm = zc_maxd(xm, zc_absd(sx[i]));
        ym = zc_maxd(ym, zc_absd(sy[i]));
    }
    double bias = 2.0 * fit + (zc_absd(za) * (xm + 16.0) + zc_absd(zb) * (ym + 16.0) + zc_absd(zc) + iwmax) * 0x1p-46;
    if (!(bias < 0.5 * (iwmax - iwmin)) || !(zc_absd(za) + zc_absd(zb) + zc_absd(zc) < INFINITY)) {
        /* Ill-conditioned (edge-on, tiny) or flat: the farthest vertex depth. */
        za = 0.0;
        zb = 0.0;
        zc = iwmin - iwmin * 0x1p-30;
    } else {
        zc -= bias;
    }
    s.zx = za;
    s.zy = zb;
    s.z0 = zc + 0.5 * za + 0.5 * zb;
    zc_traverse(t, &s);
    return 1;
}

/* Clips (near plane, and the guard band only where a vertex leaves it) and draws. */
static int zc_draw_homogeneous(vis_zc_target *t, const vis_zc_view *v, zc_hv *h, int n, int below, int above,
                               double pmax)
{
    /* All vertices beyond one plane: nothing to draw (behind the near plane, or no pixel
     * centre can be inside). Dropping an occluder is always conservative. */
    if (below & 0x1e1)
        return 0;
    if (above & 0x1f) {
        n = zc_clip(v, above & 0x1f, h, n);
        if (n < 3)
            return 0;
    }
    zc_proj pr;
    zc_project(t, h, n, &pr);
    return zc_draw_projected(t, v, &pr, n, pmax);
}

int vis_zc_draw_polygon(vis_zc_target *t, const vis_zc_view *v, const double (*p)[3], int n)
{
    if (n < 3 || n > 4)
        return 0;
    zc_hv h[VIS_ZC_MAX_VERTS];
    double pmax = 0.0;
    int below = 0x1ff, above = 0;
    for (int i = 0; i < n; i++) {
        h[i].x = v->rx[0] * p[i][0] + v->rx[1] * p[i][1] + v->rx[2] * p[i][2];
        h[i].y = v->ry[0] * p[i][0] + v->ry[1] * p[i][1] + v->ry[2] * p[i][2];
        h[i].w = v->rw[0] * p[i][0] + v->rw[1] * p[i][1] + v->rw[2] * p[i][2];
        for (int a = 0; a < 3; a++)
            pmax = zc_maxd(pmax, zc_absd(p[i][a]));
        int out = zc_outcode(v, h[i].x, h[i].y, h[i].w);
        below &= out;
        above |= out;
    }
    return zc_draw_homogeneous(t, v, h, n, below, above, pmax);
}

#if defined(ZC_HAVE_AVX2)
/* The quad front end on four lanes, one corner each: the same operations in the same order
 * as vis_zc_draw_quad's scalar code and zc_project, so the results are identical. Returns
 * the outcodes; fills pr only when no clipping is needed. */
__attribute__((target("avx2"))) static void zc_quad_front_avx2(const vis_zc_target *t, const vis_zc_view *v,
                                                               const double uv[4], uint32_t a, uint32_t ua,
                                                               uint32_t va, double pa, zc_hv *h, int *below,
                                                               int *above, zc_proj *pr)
{
    const __m256d u = _mm256_setr_pd(uv[0], uv[1], uv[1], uv[0]);
    const __m256d vv = _mm256_setr_pd(uv[2], uv[2], uv[3], uv[3]);
    const double *rows[3] = {v->rx, v->ry, v->rw};
    __m256d c[3];
    for (int r = 0; r < 3; r++) {
        const double *m = rows[r];
        __m256d A = _mm256_set1_pd(m[a] * pa);
        __m256d U = _mm256_mul_pd(_mm256_set1_pd(m[ua]), u);
        __m256d V = _mm256_mul_pd(_mm256_set1_pd(m[va]), vv);
        c[r] = _mm256_add_pd(_mm256_add_pd(A, U), V);
    }
    const __m256d x = c[0], y = c[1], w = c[2];
    const __m256d g = _mm256_mul_pd(_mm256_set1_pd(v->guard), w);
    const __m256d ng = _mm256_sub_pd(_mm256_setzero_pd(), g);
    const __m256d half = _mm256_set1_pd(0.5);
    const __m256d lw = _mm256_mul_pd(half, w);
    const __m256d rw = _mm256_mul_pd(_mm256_set1_pd(v->width - 0.5), w);
    const __m256d bw = _mm256_mul_pd(_mm256_set1_pd(v->height - 0.5), w);
    const __m256d c0 = _mm256_cmp_pd(w, _mm256_set1_pd(v->near_dist), _CMP_LT_OQ);
    const __m256d c1 = _mm256_cmp_pd(x, ng, _CMP_LT_OQ), c2 = _mm256_cmp_pd(x, g, _CMP_GT_OQ);
    const __m256d c3 = _mm256_cmp_pd(y, ng, _CMP_LT_OQ), c4 = _mm256_cmp_pd(y, g, _CMP_GT_OQ);
    /* reject planes: all four corners beyond one of them */
    int bl = (_mm256_movemask_pd(c0) == 15) | (_mm256_movemask_pd(_mm256_cmp_pd(x, lw, _CMP_LT_OQ)) == 15) << 5 |
             (_mm256_movemask_pd(_mm256_cmp_pd(x, rw, _CMP_GT_OQ)) == 15) << 6 |
             (_mm256_movemask_pd(_mm256_cmp_pd(y, lw, _CMP_LT_OQ)) == 15) << 7 |
             (_mm256_movemask_pd(_mm256_cmp_pd(y, bw, _CMP_GT_OQ)) == 15) << 8;
    int ab = 0;
    if (_mm256_movemask_pd(_mm256_or_pd(_mm256_or_pd(c0, c1), _mm256_or_pd(_mm256_or_pd(c2, c3), c4))))
        ab = (_mm256_movemask_pd(c0) != 0) | (_mm256_movemask_pd(c1) != 0) << 1 | (_mm256_movemask_pd(c2) != 0) << 2 |
             (_mm256_movemask_pd(c3) != 0) << 3 | (_mm256_movemask_pd(c4) != 0) << 4;
    *below = bl;
    *above = ab;
    if ((bl & 0x1e1) || (ab & 0x1f)) {
        /* rejected, or the generic clipper takes it from here */
        double xs[4], ys[4], ws[4];
        _mm256_storeu_pd(xs, x);
        _mm256_storeu_pd(ys, y);
        _mm256_storeu_pd(ws, w);
        for (int i = 0; i < 4; i++) {
            h[i].x = xs[i];
            h[i].y = ys[i];
            h[i].w = ws[i];
        }
        return;
    }
    const int f = t->sub_bits;
    const __m256d scale = _mm256_set1_pd((double)((int64_t)1 << f));
    const __m256d lim = _mm256_set1_pd((double)((int64_t)1 << (t->guard_bits + f)));
    const __m256d nlim = _mm256_set1_pd(-(double)((int64_t)1 << (t->guard_bits + f)));
    const __m256d magic = _mm256_set1_pd(0x1.8p52);
    const __m256d sign = _mm256_set1_pd(-0.0);
    __m256d iw = _mm256_div_pd(_mm256_set1_pd(1.0), w);
    __m256d sx = _mm256_mul_pd(x, iw), sy = _mm256_mul_pd(y, iw);
    __m256d xsc = _mm256_mul_pd(sx, scale), ysc = _mm256_mul_pd(sy, scale);
    /* zc_mind(zc_maxd(r, -lim), lim): maxpd/minpd return the second operand on ties */
    __m256d fx = _mm256_min_pd(_mm256_max_pd(_mm256_sub_pd(_mm256_add_pd(xsc, magic), magic), nlim), lim);
    __m256d fy = _mm256_min_pd(_mm256_max_pd(_mm256_sub_pd(_mm256_add_pd(ysc, magic), magic), nlim), lim);
    __m256d r = _mm256_max_pd(_mm256_andnot_pd(sign, _mm256_sub_pd(xsc, fx)), _mm256_andnot_pd(sign, _mm256_sub_pd(ysc, fy)));
    /* horizontal max/min: exact, so the order does not matter */
    __m128d r2 = _mm_max_pd(_mm256_castpd256_pd128(r), _mm256_extractf128_pd(r, 1));
    __m128d lo2 = _mm_min_pd(_mm256_castpd256_pd128(iw), _mm256_extractf128_pd(iw, 1));
    __m128d hi2 = _mm_max_pd(_mm256_castpd256_pd128(iw), _mm256_extractf128_pd(iw, 1));
    r2 = _mm_max_sd(r2, _mm_unpackhi_pd(r2, r2));
    lo2 = _mm_min_sd(lo2, _mm_unpackhi_pd(lo2, lo2));
    hi2 = _mm_max_sd(hi2, _mm_unpackhi_pd(hi2, hi2));
    pr->res = _mm_cvtsd_f64(r2);
    pr->iwmin = _mm_cvtsd_f64(lo2);
    pr->iwmax = _mm_cvtsd_f64(hi2);
    _mm256_storeu_pd(pr->iw, iw);
    _mm256_storeu_pd(pr->sx, sx);
    _mm256_storeu_pd(pr->sy, sy);
    /* |fx|, |fy| <= 2^26: exact in int32 */
    __m128i ix = _mm256_cvtpd_epi32(fx), iy = _mm256_cvtpd_epi32(fy);
    /* No pixel centre inside the bounds (most distant quads): stop here, as zc_setup_edges
     * would. Centre X*2^f + half in [min, max] for X in [0, W-1]. */
    {
        __m128i mnx = _mm_min_epi32(ix, _mm_shuffle_epi32(ix, _MM_SHUFFLE(1, 0, 3, 2)));
        __m128i mxx = _mm_max_epi32(ix, _mm_shuffle_epi32(ix, _MM_SHUFFLE(1, 0, 3, 2)));
        __m128i mny = _mm_min_epi32(iy, _mm_shuffle_epi32(iy, _MM_SHUFFLE(1, 0, 3, 2)));
        __m128i mxy = _mm_max_epi32(iy, _mm_shuffle_epi32(iy, _MM_SHUFFLE(1, 0, 3, 2)));
        mnx = _mm_min_epi32(mnx, _mm_shuffle_epi32(mnx, _MM_SHUFFLE(2, 3, 0, 1)));
        mxx = _mm_max_epi32(mxx, _mm_shuffle_epi32(mxx, _MM_SHUFFLE(2, 3, 0, 1)));
        mny = _mm_min_epi32(mny, _mm_shuffle_epi32(mny, _MM_SHUFFLE(2, 3, 0, 1)));
        mxy = _mm_max_epi32(mxy, _mm_shuffle_epi32(mxy, _MM_SHUFFLE(2, 3, 0, 1)));
        const int64_t hf = (int64_t)1 << (f - 1);
        int64_t X0 = -zc_floor_shift(hf - _mm_cvtsi128_si32(mnx), f), X1 = zc_floor_shift(_mm_cvtsi128_si32(mxx) - hf, f);
        int64_t Y0 = -zc_floor_shift(hf - _mm_cvtsi128_si32(mny), f), Y1 = zc_floor_shift(_mm_cvtsi128_si32(mxy) - hf, f);
        if (X0 < 0) X0 = 0;
        if (Y0 < 0) Y0 = 0;
        if (X1 > (int64_t)t->width - 1) X1 = (int64_t)t->width - 1;
        if (Y1 > (int64_t)t->height - 1) Y1 = (int64_t)t->height - 1;
        if (X0 > X1 || Y0 > Y1) {
            *below |= 0x100; /* reported as rejected */
            return;
        }
    }
    int32_t xi[4], yi[4];
    _mm_storeu_si128((__m128i *)xi, ix);
    _mm_storeu_si128((__m128i *)yi, iy);
    for (int i = 0; i < 4; i++) {
        pr->X[i] = xi[i];
        pr->Y[i] = yi[i];
    }
}
#endif

int vis_zc_draw_quad(vis_zc_target *t, const vis_zc_view *v, const vis_flat_quad *q)
{
    uint32_t a = VIS_META_AXIS(q->meta);
    if (a > 2)
        return 0;
    uint32_t ua = a == 2 ? 0 : a + 1, va = a == 0 ? 2 : a - 1;
    double pa = (double)q->plane - v->eye[a];
    double uv[4] = {(double)q->u0 - v->eye[ua], (double)q->u1 - v->eye[ua], (double)q->v0 - v->eye[va],
                    (double)q->v1 - v->eye[va]};
    double pmax = zc_maxd(zc_maxd(zc_absd(pa), zc_maxd(zc_absd(uv[0]), zc_absd(uv[1]))),
                          zc_maxd(zc_absd(uv[2]), zc_absd(uv[3])));
    zc_hv h[VIS_ZC_MAX_VERTS];
    int below = 0x1ff, above = 0;
#if defined(ZC_HAVE_AVX2)
    if (t->simd == VIS_ZC_SIMD_AVX2) {
        zc_proj pr;
        zc_quad_front_avx2(t, v, uv, a, ua, va, pa, h, &below, &above, &pr);
        if (below & 0x1e1)
            return 0;
        if (!(above & 0x1f))
            return zc_draw_projected(t, v, &pr, 4, pmax);
        return zc_draw_homogeneous(t, v, h, 4, below, above, pmax);
    }
#endif
    /* The corners (u0,v0), (u1,v0), (u1,v1), (u0,v1) share their terms: each row of the
     * transform costs 5 products instead of 12. */
    const double *rows[3] = {v->rx, v->ry, v->rw};
    double c[3][4];
    for (int r = 0; r < 3; r++) {
        const double *m = rows[r];
        double A = m[a] * pa, U0 = m[ua] * uv[0], U1 = m[ua] * uv[1], V0 = m[va] * uv[2], V1 = m[va] * uv[3];
        c[r][0] = (A + U0) + V0;
        c[r][1] = (A + U1) + V0;
        c[r][2] = (A + U1) + V1;
        c[r][3] = (A + U0) + V1;
    }
    for (int i = 0; i < 4; i++) {
        h[i].x = c[0][i];
        h[i].y = c[1][i];
        h[i].w = c[2][i];
        int out = zc_outcode(v, h[i].x, h[i].y, h[i].w);
        below &= out;
        above |= out;
    }
    return zc_draw_homogeneous(t, v, h, 4, below, above, pmax);
}

int vis_zc_draw_tri(vis_zc_target *t, const vis_zc_view *v, const vis_flat_tri *tri)
{
    double p[3][3];
    for (int a = 0; a < 3; a++) {
        p[0][a] = (double)tri->v0[a] - v->eye[a];
        p[1][a] = (double)tri->v1[a] - v->eye[a];
        p[2][a] = (double)tri->v2[a] - v->eye[a];
    }
    return vis_zc_draw_polygon(t, v, (const double(*)[3])p, 3);
}

/* ---- box tests ----------------------------------------------------------------------- */

vis_zc_box_class vis_zc_box_classify(const vis_zc_target *t, const vis_zc_view *v, const float lo[3],
                                     const float hi[3], vis_zc_rect *rect, double *dist)
{
    double L[3], Hh[3], d2 = 0.0, mag = 0.0;
    for (int a = 0; a < 3; a++) {
        L[a] = (double)lo[a] - v->eye[a];
        Hh[a] = (double)hi[a] - v->eye[a];
        double g = L[a] > 0 ? L[a] : (Hh[a] < 0 ? Hh[a] : 0.0);
        d2 += g * g;
        mag = zc_maxd(mag, zc_maxd(zc_absd(L[a]), zc_absd(Hh[a])));
    }
    double dd = sqrt(d2);
    if (dist)
        *dist = dd;
    /* Every hit inside the box lies at least dd from the eye. */
    if (v->far_dist < INFINITY && dd > v->far_dist * (1.0 + 1e-9))
        return VIS_ZC_BOX_CULLED;
    /* The largest value over the box of a linear function c.P is the sum over the axes of
     * the larger of c_a*lo_a and c_a*hi_a (and the smallest likewise): five planes through
     * the eye (behind it, and beyond the outermost pixel centres) without the corners.
     * Rounding slack: |P| * err_scale * a few ulps. */
    const double tol = mag * v->err_scale * 0x1p-40;
    const double W = v->width, H = v->height;
    double pl[5][3];
    for (int a = 0; a < 3; a++) {
        pl[0][a] = v->rw[a];                              /* w >= 0            */
        pl[1][a] = v->rx[a] - 0.5 * v->rw[a];             /* x >= 0.5 w        */
        pl[2][a] = (W - 0.5) * v->rw[a] - v->rx[a];       /* x <= (W - 0.5) w  */
        pl[3][a] = v->ry[a] - 0.5 * v->rw[a];
        pl[4][a] = (H - 0.5) * v->rw[a] - v->ry[a];
    }
    for (int k = 0; k < 5; k++) {
        double mx = 0.0;
        for (int a = 0; a < 3; a++)
            mx += zc_maxd(pl[k][a] * L[a], pl[k][a] * Hh[a]);
        if (mx < -tol)
            return VIS_ZC_BOX_CULLED; /* no pixel-centre ray can reach it */
    }
    double wmin = 0.0;
    for (int a = 0; a < 3; a++)
        wmin += zc_mind(v->rw[a] * L[a], v->rw[a] * Hh[a]);
    /* Reaching in front of the near plane (or around the eye): visible, conservatively. */
    if (wmin <= v->near_dist + tol + v->near_dist * 0x1p-30)
        return VIS_ZC_BOX_NEAR;
    /* The corners' screen bounds. Per axis the two products, then the sums. */
    double px[3][2], py[3][2], pw[3][2];
    for (int a = 0; a < 3; a++) {
        px[a][0] = v->rx[a] * L[a];
        px[a][1] = v->rx[a] * Hh[a];
        py[a][0] = v->ry[a] * L[a];
        py[a][1] = v->ry[a] * Hh[a];
        pw[a][0] = v->rw[a] * L[a];
        pw[a][1] = v->rw[a] * Hh[a];
    }
    double minx = INFINITY, maxx = -INFINITY, miny = INFINITY, maxy = -INFINITY;
    for (int i = 0; i < 8; i++) {
        int i0 = i & 1, i1 = (i >> 1) & 1, i2 = i >> 2;
        double cx = (px[0][i0] + px[1][i1]) + px[2][i2];
        double cy = (py[0][i0] + py[1][i1]) + py[2][i2];
        double cw = (pw[0][i0] + pw[1][i1]) + pw[2][i2];
        double iw = 1.0 / cw;
        double x = cx * iw, y = cy * iw;
        minx = zc_mind(minx, x);
        maxx = zc_maxd(maxx, x);
        miny = zc_mind(miny, y);
        maxy = zc_maxd(maxy, y);
    }
    /* Pixel centres X + 0.5 within [minx, maxx], widened by a generous rounding slack;
     * clamped to the buffer first so that the integer conversions cannot overflow. */
    double slx = (tol / wmin) + 1e-9 * (1.0 + zc_maxd(zc_absd(minx), zc_absd(maxx)));
    double sly = (tol / wmin) + 1e-9 * (1.0 + zc_maxd(zc_absd(miny), zc_absd(maxy)));
    double ax0 = zc_maxd(minx - 0.5 - slx, -1.0), ax1 = zc_mind(maxx - 0.5 + slx, W);
    double ay0 = zc_maxd(miny - 0.5 - sly, -1.0), ay1 = zc_mind(maxy - 0.5 + sly, H);
    if (!(ax0 <= ax1 && ay0 <= ay1))
        return VIS_ZC_BOX_CULLED;
    /* ceil and floor of values in [-1, W] */
    double fx0 = (double)(int64_t)(ax0 + 1.0), fx1 = (double)(int64_t)(ax1 + 1.0) - 1.0;
    double fy0 = (double)(int64_t)(ay0 + 1.0), fy1 = (double)(int64_t)(ay1 + 1.0) - 1.0;
    if (fx0 - 1.0 >= ax0)
        fx0 -= 1.0;
    if (fy0 - 1.0 >= ay0)
        fy0 -= 1.0;
    fx0 = zc_maxd(fx0, 0.0);
    fy0 = zc_maxd(fy0, 0.0);
    fx1 = zc_mind(fx1, W - 1.0);
    fy1 = zc_mind(fy1, H - 1.0);
    if (fx0 > fx1 || fy0 > fy1)
        return VIS_ZC_BOX_CULLED;
    rect->x0 = (int32_t)fx0;
    rect->y0 = (int32_t)fy0;
    rect->x1 = (int32_t)fx1;
    rect->y1 = (int32_t)fy1;
    /* Nearest depth, rounded up well past the float conversion's half ulp. */
    double iw = (1.0 / wmin) * (1.0 + 0x1p-20);
    rect->iw = iw < (double)FLT_MAX ? (float)iw : FLT_MAX;
    (void)t;
    return VIS_ZC_BOX_ON_SCREEN;
}

int vis_zc_rect_visible(const vis_zc_target *t, const vis_zc_rect *r)
{
    const float iw = r->iw;
    const int tx0 = r->x0 >> 3, tx1 = r->x1 >> 3, ty0 = r->y0 >> 3, ty1 = r->y1 >> 3;
    for (int ty = ty0; ty <= ty1; ty++) {
        int py0 = ty * 8, py1 = py0 + 7;
        int yfull = r->y0 <= py0 && (r->y1 >= py1 || (uint32_t)r->y1 == t->height - 1);
        int jy0 = r->y0 > py0 ? r->y0 - py0 : 0, jy1 = r->y1 < py1 ? r->y1 - py0 : 7;
        for (int tx = tx0; tx <= tx1; tx++) {
            size_t ti = (size_t)ty * t->tiles_x + (size_t)tx;
            /* Every pixel of the tile is nearer than the box's nearest point. */
            if (iw < t->tile_min[ti])
                continue;
            int px0 = tx * 8, px1 = px0 + 7;
            /* The rect holds the whole tile (past-the-edge pixels never set the minimum):
             * the tile's farthest pixel is in the rect. */
            if (yfull && r->x0 <= px0 && (r->x1 >= px1 || (uint32_t)r->x1 == t->width - 1))
                return 1;
            int ix0 = r->x0 > px0 ? r->x0 - px0 : 0, ix1 = r->x1 < px1 ? r->x1 - px0 : 7;
            const float *d = t->depth + ti * VIS_ZC_TILE_PIXELS;
            for (int j = jy0; j <= jy1; j++)
                for (int i = ix0; i <= ix1; i++)
                    if (d[j * 8 + i] <= iw)
                        return 1;
        }
    }
    return 0;
}
