/* gen_terrain.c — hills, overhangs, caves and a sea.
 *
 *  - Height: a per-column heightmap from fractal gradient noise (Perlin 2002, see noise.c):
 *    rolling hills plus a squared low-frequency term that raises a few mountain ranges.
 *  - Overhangs: within a band around the heightmap, and only where a 2D mask allows, solidity
 *    is (height - y) + A * noise3, so the surface can fold over itself.
 *  - Caves: "spaghetti" tunnels where two independent 3D noise fields are both near zero
 *    (the intersection of two noise iso-surfaces is a curve; thickening it gives a tunnel,
 *    the idea behind Minecraft 1.18's noise caves), plus caverns where a third field is high,
 *    deep down. Tunnels stay a few voxels below the surface except in "entrance" areas of a
 *    2D mask, where they cut through it, so a camera can walk in from outside.
 *  - Trees (only with the spec's trees=PERCENT): a trunk of wood and a crown of leaves, a
 *    see-through material, on grass; see plant_trees.
 *
 * Speed: 3D noise is evaluated only on a lattice every 4 voxels, only up to the column's
 * highest surface, and interpolated trilinearly (as Minecraft does), so a 512x128x512 world
 * needs a few million noise calls. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "generators.h"
#include "noise.h"

#define LAT 4          /* 3D noise lattice spacing, voxels                                  */
#define BAND 10        /* overhang band half-height, voxels                                 */
#define MAX_H 1024     /* tallest world this generator makes                                */
/* Bounds that rule a lattice interval out of the cave tests (see fill): a margin of 0.001
 * over the largest tunnel radius and under the smallest cavern threshold, far above the
 * rounding of the interpolation. */
#define TUNNEL_FAR 0.116
#define CAVERN_FAR 0.319
#define TREE_CELL 8    /* at most one tree per cell of this many voxels on x and z          */
#define CROWN 2        /* the crown's half-width: a tree reaches this far from its trunk    */

typedef struct terrain {
    int32_t h;                /* world height                                               */
    int32_t sea;              /* water fills air up to this y above the surface             */
    int32_t trees;            /* percent of TREE_CELL x TREE_CELL cells that try a tree     */
    uint64_t tree_seed;
    vwn_noise hills, ranges, overhang_mask, entrance, tun_a, tun_b, cavern, fold;
} terrain;

static double clampd(double v, double lo, double hi) { return v < lo ? lo : v > hi ? hi : v; }

/* The surface height from the two height fields at a column (hills: 6 octaves at 1/256,
 * ranges: 3 octaves at 1/600). */
static double height_of(const terrain *t, double hills, double r)
{
    double ranges = r > 0 ? r * r : 0.0;
    double h = t->h * (0.40 + 0.30 * hills + 0.5 * ranges);
    return clampd(h, 2.0, t->h - 4.0);
}

static double surface_height(const terrain *t, double x, double z)
{
    return height_of(t, vwn_fbm2(&t->hills, x / 256.0, z / 256.0, 6), vwn_fbm2(&t->ranges, x / 600.0, z / 600.0, 3));
}

/* 3D fields sampled on the lattice; index [field][ly][lz][lx]. */
enum { F_TUN_A, F_TUN_B, F_CAVERN, F_FOLD, F_COUNT };

/* Sets voxel (x, y, z) of the column to v where it is air. */
static void put_in_air(vwg_column *col, int32_t x, int32_t y, int32_t z, uint8_t v)
{
    uint8_t *p = vwg_at(col, x, y, z);
    if (!*p)
        *p = v;
}

/* Trees: each TREE_CELL x TREE_CELL cell holds at most one, chosen by a hash of the seed and
 * the cell, on flat grass only: where the fold band is off (no overhang), the cave entrances
 * are closed (so caves stay 5 voxels under the surface) and the ground is neither beach nor
 * snow. There the surface is exactly the heightmap's voxel, so the trunk stands on it. A tree
 * stays inside its cell (trunk 2..5 voxels in, crown CROWN wide), and cells tile chunk
 * columns (a chunk is 16 or 32 voxels, column origins are chunk multiples), so each column
 * plants its own cells' trees and no other: the world is the same for any thread count. The
 * crown (leaves) is see-through: rays pass it to what lies behind (docs/effects.md). */
_Static_assert(2 - CROWN >= 0 && 5 + CROWN < TREE_CELL && 16 % TREE_CELL == 0, "a tree stays inside its cell");
static void plant_trees(const terrain *t, vwg_column *col)
{
    const int32_t H = col->h;
    for (int32_t cz = 0; cz < col->c; cz += TREE_CELL)
        for (int32_t cx = 0; cx < col->c; cx += TREE_CELL) {
            const uint64_t gx = (uint64_t)(col->x0 + cx) / TREE_CELL, gz = (uint64_t)(col->z0 + cz) / TREE_CELL;
            const uint64_t h = vwn_mix(t->tree_seed ^ vwn_mix(gx * 0x9E3779B97F4A7C15ull ^ gz));
            if ((int32_t)(h % 100u) >= t->trees)
                continue;
            const int32_t x = cx + 2 + (int32_t)(h >> 8 & 3u), z = cz + 2 + (int32_t)(h >> 10 & 3u);
            const double wx = col->x0 + x, wz = col->z0 + z;
            const double height = surface_height(t, wx, wz);
            const int32_t hi = (int32_t)height;
            const int32_t trunk = 4 + (int32_t)(h >> 12 & 1u) + (int32_t)(h >> 13 & 1u); /* 4..6 */
            if (hi <= t->sea + 1 || hi > (int32_t)(H * 0.78) || hi + trunk + 2 >= H)
                continue; /* beach, snow, or no room under the sky */
            if (vwn_fbm2(&t->overhang_mask, wx / 180.0, wz / 180.0, 2) * 3.0 - 0.3 > 0.0)
                continue; /* the fold band may reshape the surface here */
            if (vwn_fbm2(&t->entrance, wx / 150.0, wz / 150.0, 2) > 0.22 && height > t->sea + 3)
                continue; /* a cave entrance may open the surface here */
            const int32_t top = hi + trunk;
            for (int32_t y = hi + 1; y <= top; y++)
                put_in_air(col, x, y, z, VWG_WOOD);
            for (int32_t y = top - 1; y <= top + 1; y++)
                for (int32_t dz = -CROWN; dz <= CROWN; dz++)
                    for (int32_t dx = -CROWN; dx <= CROWN; dx++)
                        if (!((dx == -CROWN || dx == CROWN) && (dz == -CROWN || dz == CROWN)))
                            put_in_air(col, x + dx, y, z + dz, VWG_LEAVES);
            for (int32_t dz = -1; dz <= 1; dz++)
                for (int32_t dx = -1; dx <= 1; dx++)
                    put_in_air(col, x + dx, top + 2, z + dz, VWG_LEAVES);
        }
}

/* Materials, top down: the sky-facing surface is grass (sand by the sea, snow high up) over
 * three voxels of dirt; everything under a cave is stone; air above the surface and below sea
 * level is water. */
static void paint_column(const terrain *t, vwg_column *col, int32_t ytop, int32_t x, int32_t z)
{
    const int32_t H = col->h;
    int32_t y = ytop;
    while (y > 0 && !*vwg_at(col, x, y, z))
        y--;
    const int32_t surface = y;
    const int beach = surface <= t->sea + 1;
    const int snowy = surface > (int32_t)(H * 0.78);
    for (int32_t k = 0; k < 4 && y - k > 0 && *vwg_at(col, x, y - k, z); k++)
        *vwg_at(col, x, y - k, z) = (uint8_t)(beach ? VWG_SAND : k == 0 ? (snowy ? VWG_SNOW : VWG_GRASS) : VWG_DIRT);
    for (int32_t w = surface + 1; w <= t->sea && w < H; w++)
        *vwg_at(col, x, w, z) = VWG_WATER;
    *vwg_at(col, x, 0, z) = VWG_BEDROCK;
}

/* What one column reads of the 3D fields: its height and fold amplitude, the highest voxel
 * it decides, its cave ceiling, and per field the lattice levels [lo, hi] it interpolates
 * (hi < lo: none). */
typedef struct column_plan {
    double h, amp;
    int32_t hi, ytop, ceil_y;
    int32_t lo_l[F_COUNT], hi_l[F_COUNT];
} column_plan;

static void plan_column(const terrain *t, const vwg_column *col, const vwn_axis *hx, const vwn_axis *hz,
                        column_plan *cp)
{
    /* surface_height and the masks' vwn_fbm2 from the column's prepared axes (axes_2d): the
     * same operations (noise.h), so the same doubles. */
    const double h = height_of(t, vwn_fbm2_axes(&t->hills, hx, hz, 6), vwn_fbm2_axes(&t->ranges, hx + 6, hz + 6, 3));
    double om = clampd(vwn_fbm2_axes(&t->overhang_mask, hx + 9, hz + 9, 2) * 3.0 - 0.3, 0.0, 1.0);
    double e = vwn_fbm2_axes(&t->entrance, hx + 11, hz + 11, 2);
    const int open = e > 0.22 && h > t->sea + 3;
    const int32_t H = col->h, hi = (int32_t)h;
    cp->h = h;
    cp->amp = om * BAND;
    cp->hi = hi;
    cp->ceil_y = hi + (open ? 2 : -5);
    cp->ytop = hi + (cp->amp > 0 ? BAND : 0);
    if (cp->ytop > H - 1)
        cp->ytop = H - 1;
    /* Only the levels a field is read at: the fold near the surface, the caves up to the
     * ceiling (FIELD reads levels y/LAT and y/LAT + 1). Both stay within the lattice:
     * ytop <= top, so ytop/LAT + 1 <= ny - 1. */
    const int32_t cave_top = cp->ceil_y < cp->ytop ? cp->ceil_y : cp->ytop;
    const int32_t cave_hi = cave_top >= 1 ? cave_top / LAT + 1 : -1;
    for (int f = F_TUN_A; f <= F_CAVERN; f++) {
        cp->lo_l[f] = 0;
        cp->hi_l[f] = cave_hi;
    }
    cp->lo_l[F_FOLD] = hi - BAND + 1 > 0 ? (hi - BAND + 1) / LAT : 0;
    cp->hi_l[F_FOLD] = cp->amp > 0 ? cp->ytop / LAT + 1 : -1;
}

/* The 2D noise coordinates of the fields a column reads, per octave, for one world x or z:
 * hills (6 octaves), ranges (3), overhang mask (2), entrance (2), as surface_height and
 * fill's masks scale them. */
enum { AXES_2D = 13 };
static void axes_2d(double w, int which, vwn_axis *out)
{
    vwn_fbm2_axes_at(w / 256.0, 6, which, out);
    vwn_fbm2_axes_at(w / 600.0, 3, which, out + 6);
    vwn_fbm2_axes_at(w / 180.0, 2, which, out + 9);
    vwn_fbm2_axes_at(w / 150.0, 2, which, out + 11);
}

/* Decides the voxels 0..ytop of column (x, z) from its profile of the fields and writes the
 * solid ones as stone (the materials come after). */
static void carve_column(const column_plan *cp, double prof[F_COUNT][MAX_H / LAT + 2], uint8_t *v, int32_t stride)
{
    static const double fy_of[LAT] = {0.0 / LAT, 1.0 / LAT, 2.0 / LAT, 3.0 / LAT}; /* (y % LAT) / LAT */
    _Static_assert(LAT == 4, "fy_of holds LAT entries");
    const double h = cp->h, amp = cp->amp;
    const int32_t hi = cp->hi, ytop = cp->ytop, ceil_y = cp->ceil_y;
    uint8_t tunnel_may[MAX_H / LAT + 2], cavern_may[MAX_H / LAT + 2];
    /* Which lattice intervals can hold a tunnel or a cavern at all. FIELD interpolates
     * between the two levels, so (up to rounding, ~1e-15 here) it lies between them: when
     * both ends of a tunnel field are beyond +-TUNNEL_FAR, |a| > 0.1159 exceeds every tunnel
     * radius (at most 0.115) and the test below is false; when both ends of the cavern field
     * are below CAVERN_FAR, it stays under every threshold (at least 0.32). Skipping those
     * tests leaves every voxel as it was, bit for bit. */
    for (int32_t ly = 0; ly < cp->hi_l[F_TUN_A]; ly++) {
        const double a0 = prof[F_TUN_A][ly], a1 = prof[F_TUN_A][ly + 1];
        const double b0 = prof[F_TUN_B][ly], b1 = prof[F_TUN_B][ly + 1];
        const int a_far = (a0 > TUNNEL_FAR && a1 > TUNNEL_FAR) || (a0 < -TUNNEL_FAR && a1 < -TUNNEL_FAR);
        const int b_far = (b0 > TUNNEL_FAR && b1 > TUNNEL_FAR) || (b0 < -TUNNEL_FAR && b1 < -TUNNEL_FAR);
        tunnel_may[ly] = !(a_far || b_far);
        cavern_may[ly] = !(prof[F_CAVERN][ly] < CAVERN_FAR && prof[F_CAVERN][ly + 1] < CAVERN_FAR);
    }
    /* Level by level (y = LAT ly + j). A level whose voxels are all stone by height (y = 0
     * always is, and is written here), below the fold band, with no cave test that can pass
     * (none at or below the ceiling, or no tunnel field near zero and no cavern: its field
     * too low or the level within 14 voxels of the surface) is written without a test per
     * voxel: the same decisions as the loop below would take. */
    const int32_t fold_from = amp > 0 ? hi - BAND : INT32_MAX; /* y above this reads the fold */
    const double r_max = 0.085 + 0.03 * 1.0, tunnel_r2_max = r_max * r_max;
    v[0] = VWG_STONE;
    for (int32_t ly = 0, y0 = 0; y0 <= ytop; ly++, y0 += LAT) {
        const int32_t y1 = y0 + LAT - 1, ycave = y0 > 0 ? y0 : 1; /* y = 0 has no cave test */
        if (y1 <= hi && y1 <= fold_from &&
            (ycave > ceil_y || (!tunnel_may[ly] && (!cavern_may[ly] || !(y0 < h - 14))))) {
            for (int32_t y = y0; y <= y1; y++)
                v[(size_t)stride * (size_t)y] = VWG_STONE;
            continue;
        }
        for (int32_t j = y0 == 0 ? 1 : 0; j < LAT && y0 + j <= ytop; j++) {
            const int32_t y = y0 + j;
            const double fy = fy_of[j];
#define FIELD(f) (prof[f][ly] + fy * (prof[f][ly + 1] - prof[f][ly]))
            int solid;
            if (y > fold_from)
                solid = (h - y) + amp * FIELD(F_FOLD) > 0;
            else
                solid = y <= hi;
            if (solid && y <= ceil_y) {
                int tunnel = 0;
                if (tunnel_may[ly]) {
                    const double a = FIELD(F_TUN_A), b = FIELD(F_TUN_B), d2 = a * a + b * b;
                    /* Tunnels get wider with depth a little; caverns only well below ground.
                     * r is at most 0.085 + 0.03 * 1.0 (rounding is monotonic), so d2 at or
                     * over that squared fails the test whatever the depth: the same answer
                     * without the division. */
                    if (d2 < tunnel_r2_max) {
                        const double r = 0.085 + 0.03 * clampd((h - y) / 40.0, 0.0, 1.0);
                        tunnel = d2 < r * r;
                    }
                }
                if (tunnel)
                    solid = 0;
                else if (cavern_may[ly] && y < h - 14 &&
                         FIELD(F_CAVERN) > 0.42 - 0.1 * clampd((h - 14 - y) / 30.0, 0.0, 1.0))
                    solid = 0;
            }
#undef FIELD
            if (solid)
                v[(size_t)stride * (size_t)y] = VWG_STONE;
        }
    }
}

/* `scratch`: one column's 3D lattice (lattice_bytes), the worker's own. */
static void fill(const void *state, void *scratch, vwg_column *col)
{
    const terrain *t = state;
    const int32_t c = col->c, H = col->h;
    const int32_t nl = c / LAT + 1;          /* lattice points per horizontal axis         */

    /* Per column: height, overhang amplitude, cave ceiling, levels read; the 2D noise from
     * coordinates prepared once per x and per z. */
    column_plan plan[32 * 32];
    vwn_axis ax2[32][AXES_2D], az2[32][AXES_2D];
    for (int32_t i = 0; i < c; i++) {
        axes_2d((double)(col->x0 + i), VWN_FBM_X, ax2[i]);
        axes_2d((double)(col->z0 + i), VWN_FBM_Y, az2[i]);
    }
    int32_t top = 0;
    int32_t need_lo[F_COUNT], need_hi[F_COUNT]; /* levels any column reads, per field */
    for (int f = 0; f < F_COUNT; f++) {
        need_lo[f] = INT32_MAX;
        need_hi[f] = -1;
    }
    for (int32_t z = 0; z < c; z++)
        for (int32_t x = 0; x < c; x++) {
            column_plan *cp = &plan[x + c * z];
            plan_column(t, col, ax2[x], az2[z], cp);
            if (cp->hi + BAND + 1 > top)
                top = cp->hi + BAND + 1;
            for (int f = 0; f < F_COUNT; f++)
                if (cp->hi_l[f] >= cp->lo_l[f]) {
                    need_lo[f] = cp->lo_l[f] < need_lo[f] ? cp->lo_l[f] : need_lo[f];
                    need_hi[f] = cp->hi_l[f] > need_hi[f] ? cp->hi_l[f] : need_hi[f];
                }
        }
    if (top > H - 1)
        top = H - 1;

    /* The lattice, up to the highest point any column can reach, at the levels some column
     * reads (the others are never looked at). */
    const int32_t ny = top / LAT + 2;
    const size_t fs = (size_t)ny * (size_t)nl * (size_t)nl;
    double *lat = scratch;
    {
        static const double sxz[F_COUNT] = {44.0, 44.0, 70.0, 16.0}, sy[F_COUNT] = {30.0, 30.0, 36.0, 8.0};
        const vwn_noise *field[F_COUNT] = {&t->tun_a, &t->tun_b, &t->cavern, &t->fold};
        vwn_axis ax[32 / LAT + 1], az[32 / LAT + 1], ay;
        for (int f = 0; f < F_COUNT; f++) {
            for (int32_t l = 0; l < nl; l++) {
                ax[l] = vwn_axis_at((double)(col->x0 + l * LAT) / sxz[f]);
                az[l] = vwn_axis_at((double)(col->z0 + l * LAT) / sxz[f]);
            }
            for (int32_t ly = need_lo[f]; ly <= need_hi[f]; ly++) {
                ay = vwn_axis_at((double)(ly * LAT) / sy[f]);
                for (int32_t lz = 0; lz < nl; lz++)
                    vwn_perlin3_row(field[f], ax, nl, &ay, &az[lz],
                                    &lat[f * fs + (size_t)nl * ((size_t)lz + (size_t)nl * (size_t)ly)]);
            }
        }
    }

    /* Bilinear in x, z at each lattice level: the x-interpolated rows lz and lz + 1 (the
     * same values for the LAT columns between them) once per x and lattice row, then z per
     * column. */
    double prof[F_COUNT][MAX_H / LAT + 2];      /* one column's fields at each lattice level */
    double row0[F_COUNT][MAX_H / LAT + 2], row1[F_COUNT][MAX_H / LAT + 2];
    for (int32_t lz = 0; lz < c / LAT; lz++)
        for (int32_t x = 0; x < c; x++) {
            const int32_t lx = x / LAT;
            const double fx = (double)(x % LAT) / LAT;
            for (int f = 0; f < F_COUNT; f++) {
                int32_t lo = INT32_MAX, hi = -1;
                for (int32_t j = 0; j < LAT; j++) {
                    const column_plan *cp = &plan[x + c * (lz * LAT + j)];
                    if (cp->hi_l[f] >= cp->lo_l[f]) {
                        lo = cp->lo_l[f] < lo ? cp->lo_l[f] : lo;
                        hi = cp->hi_l[f] > hi ? cp->hi_l[f] : hi;
                    }
                }
                for (int32_t ly = lo; ly <= hi; ly++) {
                    const double *p = &lat[f * fs + (size_t)nl * (size_t)nl * (size_t)ly];
                    double a = p[lx + nl * lz], b = p[lx + 1 + nl * lz];
                    double cc = p[lx + nl * (lz + 1)], d = p[lx + 1 + nl * (lz + 1)];
                    row0[f][ly] = a + fx * (b - a);
                    row1[f][ly] = cc + fx * (d - cc);
                }
            }
            for (int32_t j = 0; j < LAT; j++) {
                const int32_t z = lz * LAT + j;
                const column_plan *cp = &plan[x + c * z];
                const double fz = (double)(z % LAT) / LAT;
                for (int f = 0; f < F_COUNT; f++)
                    for (int32_t ly = cp->lo_l[f]; ly <= cp->hi_l[f]; ly++)
                        prof[f][ly] = row0[f][ly] + fz * (row1[f][ly] - row0[f][ly]);
                carve_column(cp, prof, vwg_at(col, x, 0, z), c);
                paint_column(t, col, cp->ytop, x, z);
            }
        }
    if (t->trees > 0)
        plant_trees(t, col);
}

static void destroy(void *state) { free(state); }

/* The lattice of one column: F_COUNT fields of (H/LAT + 2) layers of nl x nl points. */
static size_t lattice_bytes(int32_t height, int32_t chunk)
{
    const size_t nl = (size_t)chunk / LAT + 1;
    return sizeof(double) * F_COUNT * ((size_t)height / LAT + 2) * nl * nl;
}

uint64_t vwg_terrain_scratch_bytes(const int32_t size[3], int32_t chunk)
{
    (void)size;
    (void)chunk;
    return sizeof(terrain);
}

uint64_t vwg_terrain_worker_bytes(const int32_t size[3], int32_t chunk)
{
    /* Heights past MAX_H are refused before anything is allocated. */
    return lattice_bytes(size[1] < MAX_H ? size[1] : MAX_H, chunk);
}

vw_status vwg_terrain_create(vw_world *w, uint64_t seed, int32_t trees, vwg_generator *out, vw_error *err)
{
    if (w->size[1] > MAX_H)
        return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "terrain: height %d is over the generator's limit of %d voxels",
                        (int)w->size[1], MAX_H);
    terrain *t = calloc(1, sizeof *t);
    if (!t)
        return vwi_fail(err, VW_ERROR_OUT_OF_MEMORY, "terrain: out of memory");
    t->h = w->size[1];
    t->sea = (int32_t)(t->h * 0.34);
    t->trees = trees;
    t->tree_seed = vwn_mix(seed * 0x100000001B3ull + 0x7EE5u);
    vwn_noise *fields[] = {&t->hills, &t->ranges, &t->overhang_mask, &t->entrance,
                           &t->tun_a, &t->tun_b, &t->cavern, &t->fold};
    for (size_t i = 0; i < sizeof fields / sizeof fields[0]; i++)
        vwn_init(fields[i], vwn_mix(seed * 0x100000001B3ull + i));
    vwg_set_palette(w);
    out->state = t;
    out->fill = fill;
    out->destroy = destroy;
    out->worker_bytes = lattice_bytes(w->size[1], w->chunk_size);
    return VW_OK;
}
