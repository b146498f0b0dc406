/* noise.h — seeded coherent noise and hashing for the generators (internal). */
#ifndef VOXELWORLD_NOISE_H
#define VOXELWORLD_NOISE_H

#include <stdint.h>

/* One noise field: Perlin's permutation table, shuffled by a seed. Fields made from different
 * seeds are independent, which is how a generator gets several (height, caves, ...). */
typedef struct vwn_noise {
    uint8_t perm[512];
} vwn_noise;

void vwn_init(vwn_noise *n, uint64_t seed);

/* Gradient noise in about [-1, 1], 0 at integer lattice points. */
double vwn_perlin2(const vwn_noise *n, double x, double y);
double vwn_perlin3(const vwn_noise *n, double x, double y, double z);

/* Fractal sum of `octaves` octaves (frequency x2, amplitude x0.5 per octave), normalised to
 * about [-1, 1]. */
double vwn_fbm2(const vwn_noise *n, double x, double y, int octaves);

/* The same noise from coordinates prepared once per axis. Points of a lattice or a grid of
 * columns share their coordinate on each axis, so the work that depends on one coordinate
 * only (its cell, the offset in the cell and the offset's fade) can be done once per
 * coordinate instead of once per sample. The functions below do the arithmetic of the ones
 * above, operation for operation, so they return the same doubles bit for bit (vwn_perlin3,
 * vwn_perlin2 and vwn_fbm2 are written on top of the same code). */
typedef struct vwn_axis {
    int cell;       /* floor(c) & 255                                                        */
    double t, fade; /* c - floor(c), and its quintic fade                                     */
} vwn_axis;

vwn_axis vwn_axis_at(double c);
/* vwn_perlin3 at (x[i], y, z) for i < count into out[i]. */
void vwn_perlin3_row(const vwn_noise *n, const vwn_axis *x, int count, const vwn_axis *y, const vwn_axis *z,
                     double *out);

/* The coordinates vwn_fbm2 samples on one axis: octave o at c * 2^o + 17.31 * o (VWN_FBM_X)
 * or c * 2^o - 9.71 * o (VWN_FBM_Y), into out[0..octaves). */
enum { VWN_FBM_X, VWN_FBM_Y };
#define VWN_FBM_MAX_OCTAVES 16 /* vwn_fbm2 sums at most this many (the generators use 2 to 6) */
void vwn_fbm2_axes_at(double c, int octaves, int which, vwn_axis *out);
/* vwn_fbm2 at the point whose octave coordinates are x[o], y[o] (vwn_fbm2_axes_at). */
double vwn_fbm2_axes(const vwn_noise *n, const vwn_axis *x, const vwn_axis *y, int octaves);

/* splitmix64 (Steele, Lea, Flood 2014): a well-mixed 64-bit hash for per-cell decisions. */
uint64_t vwn_mix(uint64_t x);
/* Uniform in [0, 1) from a hash of (seed, a, b, c). */
double vwn_unit(uint64_t seed, int64_t a, int64_t b, int64_t c);

#endif
