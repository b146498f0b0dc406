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

/* splitmix64 (Steele, Lea, Flood 2014): a well-mixed 64-bit hash for per-cell decisions. */
uint64_t vwn_mix(uint64_t x);
/* Uniform in [0, 1) from a hash of (seed, a, b, c). */
double vwn_unit(uint64_t seed, int64_t a, int64_t b, int64_t c);

#endif
