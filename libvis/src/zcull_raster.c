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
    __m256 lane = _mm256_loadu_ps(jb->lane);
    __m256i iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    __m256i ea[ZC_MAXE];
    for (int k = 0; k < jb->nc; k++)
        ea[k] = _mm256_mullo_epi32(_mm256_set1_epi32(jb->a[k]), iota);
    __m256 mn = _mm256_set1_ps(FLT_MAX);
    __m256i one = _mm256_set1_epi32(1);
    for (int j = 0; j < 8; j++) {
        __m256i m = _mm256_setzero_si256();
        for (int k = 0; k < jb->nc; k++)
            m = _mm256_or_si256(m, _mm256_add_epi32(_mm256_set1_epi32(jb->e[k] + jb->b[k] * j), ea[k]));
        if (jb->count) {
            __m256i *c = (__m256i *)(jb->count + j * 8);
            __m256i inc = _mm256_add_epi32(one, _mm256_srai_epi32(m, 31));
            _mm256_storeu_si256(c, _mm256_add_epi32(_mm256_loadu_si256(c), inc));
            continue;
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
 * never reaches these (inputs are finite by construction). */
static inline double zc_maxd(double a, double b) { return a > b ? a : b; }
static inline double zc_mind(double a, double b) { return a < b ? a : b; }
static inline double zc_absd(double a) { return a < 0 ? -a : a; }

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
    int64_t area2 = 0;
    for (int i = 0; i < n; i++) {
        int j = i + 1 == n ? 0 : i + 1;
        area2 += xin[i] * yin[j] - xin[j] * yin[i];
    }
    if (area2 == 0)
        return 0;
    /* Wind the polygon so that its inside is where every edge function is positive. */
    int64_t x[ZC_MAXE], y[ZC_MAXE], mg[ZC_MAXE];
    for (int i = 0; i < n; i++) {
        int src = area2 > 0 ? i : n - 1 - i;
        x[i] = xin[src];
        y[i] = yin[src];
        /* reversed, edge i runs from old vertex n-1-i to n-2-i: old edge n-2-i */
        int se = area2 > 0 ? i : (2 * n - 2 - i) % n;
        mg[i] = margin_in ? margin_in[se] : 0;
    }
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
    s->n = n;
    s->x0 = (int32_t)X0;
    s->y0 = (int32_t)Y0;
    s->x1 = (int32_t)X1;
    s->y1 = (int32_t)Y1;
    /* Traversal touches whole tiles: the shrink bound must hold for every centre in them. */
    double cx0 = (double)((X0 & ~(int64_t)7) << f) + (double)half;
    double cx1 = (double)((X1 | 7) << f) + (double)half;
    double cy0 = (double)((Y0 & ~(int64_t)7) << f) + (double)half;
    double cy1 = (double)((Y1 | 7) << f) + (double)half;
    for (int i = 0; i < n; i++) {
        int j = i + 1 == n ? 0 : i + 1;
        int64_t dx = x[j] - x[i], dy = y[j] - y[i];
        int64_t m = mg[i];
        if (eps >= 0) {
            /* E_exact(p) - E_snapped(p) = cross(d, q) - cross(D + d, e0) with q = p - v_i,
             * e the vertex errors (|e| <= eps per coordinate), d = e_j - e_i. */
            double qx = zc_maxd(zc_absd(cx0 - (double)x[i]), zc_absd(cx1 - (double)x[i]));
            double qy = zc_maxd(zc_absd(cy0 - (double)y[i]), zc_absd(cy1 - (double)y[i]));
            double bound = 2.0 * eps * (qx + qy) + eps * (zc_absd((double)dx) + zc_absd((double)dy)) + 4.0 * eps * eps;
            m = (int64_t)bound + 2; /* >= ceil(bound) + 1 */
        }
        /* Top-left rule (y down, inside on the left of each edge): a top edge runs right
         * (dy == 0, dx > 0), a left edge runs up (dy < 0). Others exclude E == 0. */
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

static void zc_traverse(vis_zc_target *t, const zc_setup *s)
{
    const int n = s->n;
    const int depth_mode = t->count == NULL;
    zc_tile_fn kernel = zc_tile_kernel(t->simd);
    zc_tile_job job;
    float lane[8], row[8];
    float za = (float)s->zx, zb = (float)s->zy;
    float lane_max = 0.0f, row_max = 0.0f;
    for (int i = 0; i < 8; i++) {
        lane[i] = za * (float)i;
        row[i] = zb * (float)i;
        lane_max = lane[i] > lane_max ? lane[i] : lane_max;
        row_max = row[i] > row_max ? row[i] : row_max;
    }
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
    t->polygons++;
    for (int ty = ty0; ty <= ty1; ty++) {
        for (int k = 0; k < n; k++)
            e[k] = erow[k];
        for (int tx = tx0; tx <= tx1; tx++) {
            int reject = 0, nc = 0;
            for (int k = 0; k < n; k++) {
                if (e[k] + hi[k] < 0) {
                    reject = 1;
                    break;
                }
                if (e[k] + lo[k] < 0) {
                    job.e[nc] = (int32_t)e[k];
                    job.a[nc] = (int32_t)s->a[k];
                    job.b[nc] = (int32_t)s->b[k];
                    nc++;
                }
            }
            if (!reject) {
                size_t ti = (size_t)ty * t->tiles_x + (size_t)tx;
                job.nc = nc;
                if (depth_mode) {
                    /* Lowered by a bound on the float evaluation error of every pixel of
                     * the tile: each of the five roundings (dT, za, zb, row, lane and the two
                     * sums) is within 2^-24 of |dT| + 7(|za| + |zb|); 2^-21 covers them. */
                    double pt = s->z0 + s->zx * (double)(tx * 8) + s->zy * (double)(ty * 8);
                    float dt = (float)(pt - (zc_absd(pt) + zgrad8) * 0x1p-21);
                    /* Rounded addition is monotonic, so this bounds every value the kernel
                     * computes: skip tiles already nearer everywhere (hierarchical test). */
                    float dmax = (dt + row_max) + lane_max;
                    if (dmax > t->tile_min[ti]) {
                        job.dt = dt;
                        job.depth = t->depth + ti * VIS_ZC_TILE_PIXELS;
                        t->tile_min[ti] = kernel(&job);
                        t->tiles++;
                    }
                } else {
                    job.dt = 0.0f;
                    job.depth = t->depth + ti * VIS_ZC_TILE_PIXELS;
                    job.count = t->count + ti * VIS_ZC_TILE_PIXELS;
                    kernel(&job);
                    job.count = NULL;
                    t->tiles++;
                }
            }
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

int vis_zc_draw_polygon(vis_zc_target *t, const vis_zc_view *v, const double (*p)[3], int n)
{
    if (n < 3 || n > 4)
        return 0;
    zc_hv h[VIS_ZC_MAX_VERTS];
    double pmax = 0.0;
    int below = 0x7ff, above = 0;
    const double W = v->width, H = v->height;
    for (int i = 0; i < n; i++) {
        h[i].x = v->rx[0] * p[i][0] + v->rx[1] * p[i][1] + v->rx[2] * p[i][2];
        h[i].y = v->ry[0] * p[i][0] + v->ry[1] * p[i][1] + v->ry[2] * p[i][2];
        h[i].w = v->rw[0] * p[i][0] + v->rw[1] * p[i][1] + v->rw[2] * p[i][2];
        for (int a = 0; a < 3; a++)
            pmax = zc_maxd(pmax, zc_absd(p[i][a]));
        /* outside the pixel centres: left, right, top, bottom; then the clip planes */
        int out = 0;
        out |= (h[i].x < 0.5 * h[i].w) << 5;
        out |= (h[i].x > (W - 0.5) * h[i].w) << 6;
        out |= (h[i].y < 0.5 * h[i].w) << 7;
        out |= (h[i].y > (H - 0.5) * h[i].w) << 8;
        for (int q = 0; q < 5; q++)
            out |= (zc_plane_dist(v, q, h[i]) < 0) << q;
        below &= out;
        above |= out;
    }
    /* All vertices beyond one plane: nothing to draw (behind the near plane, or no pixel
     * centre can be inside). Dropping an occluder is always conservative. */
    if (below & 0x1e1)
        return 0;
    if (above & 0x1f)
        n = zc_clip(v, above & 0x1f, h, n);
    if (n < 3)
        return 0;

    const int f = t->sub_bits;
    const double scale = (double)((int64_t)1 << f);
    const double lim = (double)((int64_t)1 << (t->guard_bits + f));
    double sx[VIS_ZC_MAX_VERTS], sy[VIS_ZC_MAX_VERTS], iw[VIS_ZC_MAX_VERTS];
    int64_t X[VIS_ZC_MAX_VERTS], Y[VIS_ZC_MAX_VERTS];
    double res = 0.0, wmin = INFINITY, iwmin = INFINITY, iwmax = 0.0;
    for (int i = 0; i < n; i++) {
        double w = h[i].w;
        iw[i] = 1.0 / w;
        sx[i] = h[i].x * iw[i];
        sy[i] = h[i].y * iw[i];
        wmin = zc_mind(wmin, w);
        iwmin = zc_mind(iwmin, iw[i]);
        iwmax = zc_maxd(iwmax, iw[i]);
        double fx = zc_mind(zc_maxd(zc_round(sx[i] * scale), -lim), lim);
        double fy = zc_mind(zc_maxd(zc_round(sy[i] * scale), -lim), lim);
        res = zc_maxd(res, zc_maxd(zc_absd(sx[i] * scale - fx), zc_absd(sy[i] * scale - fy)));
        X[i] = (int64_t)fx;
        Y[i] = (int64_t)fy;
    }
    if (!(wmin > 0.0))
        return 0;
    /* Bound (in sub-pixels) on how far each snapped coordinate is from the exact projection:
     * the snapping residual plus the double rounding of transform, clip and divide, which is
     * a few ulps of |P| * err_scale / w (2^-44 leaves a wide margin). */
    double eps = res + (pmax * v->err_scale / wmin) * 0x1p-44 * scale + 0x1p-30;
    zc_setup s;
    if (!zc_setup_edges(t, n, X, Y, NULL, eps, &s))
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
    if (!(bias < 0.5 * (iwmax - iwmin)) || !isfinite(za) || !isfinite(zb) || !isfinite(zc)) {
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

int vis_zc_draw_quad(vis_zc_target *t, const vis_zc_view *v, const vis_flat_quad *q)
{
    uint32_t a = VIS_META_AXIS(q->meta);
    if (a > 2)
        return 0;
    uint32_t ua = (a + 1) % 3, va = (a + 2) % 3;
    double pa = (double)q->plane - v->eye[a];
    double u0 = (double)q->u0 - v->eye[ua], u1 = (double)q->u1 - v->eye[ua];
    double v0 = (double)q->v0 - v->eye[va], v1 = (double)q->v1 - v->eye[va];
    double p[4][3];
    p[0][a] = pa; p[0][ua] = u0; p[0][va] = v0;
    p[1][a] = pa; p[1][ua] = u1; p[1][va] = v0;
    p[2][a] = pa; p[2][ua] = u1; p[2][va] = v1;
    p[3][a] = pa; p[3][ua] = u0; p[3][va] = v1;
    return vis_zc_draw_polygon(t, v, (const double(*)[3])p, 4);
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
    zc_hv c[8];
    for (int i = 0; i < 8; i++) {
        double P[3] = {(i & 1) ? Hh[0] : L[0], (i & 2) ? Hh[1] : L[1], (i & 4) ? Hh[2] : L[2]};
        c[i].x = v->rx[0] * P[0] + v->rx[1] * P[1] + v->rx[2] * P[2];
        c[i].y = v->ry[0] * P[0] + v->ry[1] * P[1] + v->ry[2] * P[2];
        c[i].w = v->rw[0] * P[0] + v->rw[1] * P[1] + v->rw[2] * P[2];
    }
    /* Rounding slack of the corner transforms (|P| * err_scale * a few ulps). */
    double tol = mag * v->err_scale * 0x1p-40;
    const double W = v->width, H = v->height;
    /* Culled only when the whole box is strictly beyond one plane through the outermost
     * pixel centres (or behind the eye): no pixel-centre ray can reach it. */
    int below = 0x1f;
    double wmin = INFINITY;
    for (int i = 0; i < 8; i++) {
        int out = 0;
        out |= (c[i].w < -tol) << 0;
        out |= (c[i].x - 0.5 * c[i].w < -tol) << 1;
        out |= ((W - 0.5) * c[i].w - c[i].x < -tol) << 2;
        out |= (c[i].y - 0.5 * c[i].w < -tol) << 3;
        out |= ((H - 0.5) * c[i].w - c[i].y < -tol) << 4;
        below &= out;
        wmin = zc_mind(wmin, c[i].w);
    }
    if (below)
        return VIS_ZC_BOX_CULLED;
    /* Reaching in front of the near plane (or around the eye): visible, conservatively. */
    if (wmin <= v->near_dist + tol + v->near_dist * 0x1p-30)
        return VIS_ZC_BOX_NEAR;
    double minx = INFINITY, maxx = -INFINITY, miny = INFINITY, maxy = -INFINITY;
    for (int i = 0; i < 8; i++) {
        double iw = 1.0 / c[i].w;
        double x = c[i].x * iw, y = c[i].y * iw;
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
