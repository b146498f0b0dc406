/* noise.c — gradient noise for terrain: Ken Perlin, "Improving Noise", SIGGRAPH 2002
 * (quintic fade 6t^5 - 15t^4 + 10t^3, gradients to the 12 cube edge midpoints chosen by the
 * low 4 bits of the hash). The permutation is shuffled per seed (Fisher-Yates driven by
 * splitmix64) instead of Perlin's fixed table, so every seed is a different world and the
 * result depends on nothing but the seed and the coordinates. */
#include <math.h>

#include "noise.h"

uint64_t vwn_mix(uint64_t x)
{
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

double vwn_unit(uint64_t seed, int64_t a, int64_t b, int64_t c)
{
    uint64_t h = vwn_mix(seed ^ vwn_mix((uint64_t)a ^ vwn_mix((uint64_t)b ^ vwn_mix((uint64_t)c))));
    return (double)(h >> 11) * (1.0 / 9007199254740992.0);
}

void vwn_init(vwn_noise *n, uint64_t seed)
{
    for (int i = 0; i < 256; i++)
        n->perm[i] = (uint8_t)i;
    uint64_t state = seed;
    for (int i = 255; i > 0; i--) {
        state = vwn_mix(state);
        int j = (int)(state % (uint64_t)(i + 1));
        uint8_t t = n->perm[i];
        n->perm[i] = n->perm[j];
        n->perm[j] = t;
    }
    for (int i = 0; i < 256; i++)
        n->perm[256 + i] = n->perm[i];
}

static double fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }
static double lerp(double t, double a, double b) { return a + t * (b - a); }

/* The gradients as coefficient tables instead of Perlin's branches (which the compiler keeps
 * as branches: on random hash bits they are mispredicted about half the time). Row h gives
 * exactly the terms of Perlin's grad(h, x, y, z): h < 8 takes x and y or z, h >= 8 takes y and
 * z, 12 and 14 repeat x + y and -x + y. Each product is exact (a coefficient of 0 or +-1), and
 * the sum equals Perlin's u + v in value: a zero term adds a zero, which can change only the
 * sign of a zero result, and no caller can tell +0 from -0 (they add, multiply and compare).
 * tests/test_generators.c checks the worlds against ones recorded with the branching code. */
static const double g3x[16] = {1, -1, 1, -1, 1, -1, 1, -1, 0, 0, 0, 0, 1, 0, -1, 0};
static const double g3y[16] = {1, 1, -1, -1, 0, 0, 0, 0, 1, -1, 1, -1, 1, -1, 1, -1};
static const double g3z[16] = {0, 0, 0, 0, 1, 1, -1, -1, 1, 1, -1, -1, 0, 1, 0, -1};

static inline double grad3(int hash, double x, double y, double z)
{
    const int h = hash & 15;
    return g3x[h] * x + g3y[h] * y + g3z[h] * z;
}

/* Eight unit-ish directions in the plane, the 2D analogue of the cube-edge gradients:
 * x + y, -x + y, x - y, -x - y, x, -x, y, -y (tables for the reason given above). */
static const double g2x[8] = {1, -1, 1, -1, 1, -1, 0, 0};
static const double g2y[8] = {1, 1, -1, -1, 0, 0, 1, -1};

static inline double grad2(int hash, double x, double y)
{
    const int h = hash & 7;
    return g2x[h] * x + g2y[h] * y;
}

vwn_axis vwn_axis_at(double c)
{
    const double f = floor(c);
    const double t = c - f;
    vwn_axis a = {(int)f & 255, t, fade(t)};
    return a;
}

static inline double perlin3(const vwn_noise *n, const vwn_axis *ax, const vwn_axis *ay, const vwn_axis *az)
{
    const double x = ax->t, y = ay->t, z = az->t, u = ax->fade, v = ay->fade, w = az->fade;
    const int X = ax->cell, Y = ay->cell, Z = az->cell;
    const uint8_t *p = n->perm;
    int A = p[X] + Y, AA = p[A] + Z, AB = p[A + 1] + Z;
    int B = p[X + 1] + Y, BA = p[B] + Z, BB = p[B + 1] + Z;
    return lerp(w,
                lerp(v, lerp(u, grad3(p[AA], x, y, z), grad3(p[BA], x - 1, y, z)),
                     lerp(u, grad3(p[AB], x, y - 1, z), grad3(p[BB], x - 1, y - 1, z))),
                lerp(v, lerp(u, grad3(p[AA + 1], x, y, z - 1), grad3(p[BA + 1], x - 1, y, z - 1)),
                     lerp(u, grad3(p[AB + 1], x, y - 1, z - 1), grad3(p[BB + 1], x - 1, y - 1, z - 1))));
}

static inline double perlin2(const vwn_noise *n, const vwn_axis *ax, const vwn_axis *ay)
{
    const double x = ax->t, y = ay->t, u = ax->fade, v = ay->fade;
    const uint8_t *p = n->perm;
    int A = p[ax->cell] + ay->cell, B = p[ax->cell + 1] + ay->cell;
    return lerp(v, lerp(u, grad2(p[A], x, y), grad2(p[B], x - 1, y)),
                      lerp(u, grad2(p[A + 1], x, y - 1), grad2(p[B + 1], x - 1, y - 1)));
}

void vwn_perlin3_row(const vwn_noise *n, const vwn_axis *x, int count, const vwn_axis *y, const vwn_axis *z,
                     double *out)
{
    for (int i = 0; i < count; i++)
        out[i] = perlin3(n, &x[i], y, z);
}

double vwn_perlin3(const vwn_noise *n, double x, double y, double z)
{
    const vwn_axis ax = vwn_axis_at(x), ay = vwn_axis_at(y), az = vwn_axis_at(z);
    return perlin3(n, &ax, &ay, &az);
}

double vwn_perlin2(const vwn_noise *n, double x, double y)
{
    const vwn_axis ax = vwn_axis_at(x), ay = vwn_axis_at(y);
    return perlin2(n, &ax, &ay);
}

void vwn_fbm2_axes_at(double c, int octaves, int which, vwn_axis *out)
{
    for (int o = 0; o < octaves; o++) {
        /* An odd offset per octave keeps the lattice points of octaves from lining up. */
        out[o] = vwn_axis_at(which == VWN_FBM_X ? c + 17.31 * o : c - 9.71 * o);
        c *= 2.0;
    }
}

double vwn_fbm2_axes(const vwn_noise *n, const vwn_axis *x, const vwn_axis *y, int octaves)
{
    double sum = 0.0, amp = 1.0, norm = 0.0;
    for (int o = 0; o < octaves; o++) {
        sum += amp * perlin2(n, &x[o], &y[o]);
        norm += amp;
        amp *= 0.5;
    }
    /* The sum's spread shrinks as octaves average out; 1.8 (measured over 4M samples of 6
     * octaves: extremes about +-0.98, rms 0.28) brings it back to about [-1, 1]. */
    return 1.8 * sum / norm;
}

double vwn_fbm2(const vwn_noise *n, double x, double y, int octaves)
{
    vwn_axis ax[VWN_FBM_MAX_OCTAVES], ay[VWN_FBM_MAX_OCTAVES];
    if (octaves > VWN_FBM_MAX_OCTAVES)
        octaves = VWN_FBM_MAX_OCTAVES;
    vwn_fbm2_axes_at(x, octaves, VWN_FBM_X, ax);
    vwn_fbm2_axes_at(y, octaves, VWN_FBM_Y, ay);
    return vwn_fbm2_axes(n, ax, ay, octaves);
}
