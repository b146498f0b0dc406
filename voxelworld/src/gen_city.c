/* gen_city.c — streets on a grid and buildings with floors, rooms, windows and doors.
 *
 * The plan repeats every BLOCK voxels on x and z: a street band, then a lot cut into 2x2
 * parcels. Each parcel's building is a pure function of (seed, parcel), so any column can be
 * generated alone: margins, floor count, window spacing and width, glazing and door side
 * all come from one hash. Inside, each storey is a slab plus FLOOR-1 voxels of rooms: a
 * 1-voxel outer wall with 1-2 voxel wide, 2 voxel tall windows, inner walls on the two
 * middle lines with door gaps (so rooms connect), a street door on the ground floor, and
 * furniture just inside the outer walls — the small objects that a culler must find through
 * a window or miss behind a wall. */
#include <stdlib.h>

#include "generators.h"
#include "noise.h"

#define BLOCK 48     /* street pitch                                                         */
#define STREET 8     /* street band width, curbs included                                    */
#define FLOOR 5      /* voxels per storey: one slab, four of room                            */
#define GROUND 1     /* y of the first voxel above the ground slab                           */

typedef struct city {
    uint64_t seed;
    int32_t max_floors;
} city;

typedef struct building {
    int32_t x0, z0, x1, z1;   /* footprint [x0, x1) x [z0, z1)                              */
    int32_t floors;           /* 0: an empty parcel (a plaza)                               */
    int32_t win_pitch;        /* a window every win_pitch voxels along a wall               */
    int32_t win_width;        /* 1 or 2                                                     */
    int glass;                /* windows glazed (see-through) instead of open                */
    int door_side;            /* 0: -z, 1: +z, 2: -x, 3: +x                                 */
    uint64_t hash;
} building;

static void parcel(const city *c, int32_t x, int32_t z, building *b)
{
    const int32_t bx = x / BLOCK, bz = z / BLOCK;
    const int32_t half = (BLOCK - STREET) / 2;
    const int32_t px = (x % BLOCK - STREET) / half, pz = (z % BLOCK - STREET) / half;
    const uint64_t h = vwn_mix(c->seed ^ vwn_mix(((uint64_t)(uint32_t)bx << 32 | (uint32_t)bz) * 4 + (uint64_t)(px + 2 * pz)));
    const int32_t ox = bx * BLOCK + STREET + px * half, oz = bz * BLOCK + STREET + pz * half;
    b->hash = h;
    b->x0 = ox + 1 + (int32_t)(h % 3);
    b->x1 = ox + half - 1 - (int32_t)(h >> 2 & 1) - (int32_t)(h >> 3 & 1);
    b->z0 = oz + 1 + (int32_t)(h >> 4 & 1) + (int32_t)(h >> 5 & 1);
    b->z1 = oz + half - 1 - (int32_t)(h >> 6 & 1);
    int32_t floors = 2 + (int32_t)(h >> 8 & 7);
    if ((h >> 12 & 7) == 0)
        floors += 8 + (int32_t)(h >> 16 & 7); /* now and then a tower */
    if ((h >> 20 & 15) == 0)
        floors = 0;                           /* and now and then a plaza */
    b->floors = floors < c->max_floors ? floors : c->max_floors;
    b->win_pitch = 3 + (int32_t)(h >> 24 & 1);
    b->win_width = 1 + (int32_t)(h >> 25 & 1);
    b->glass = (h >> 26 & 3) == 0;
    b->door_side = (int)(h >> 28 & 3);
}

/* Position along the outer wall and which side, for a perimeter cell. */
static int wall_side(const building *b, int32_t x, int32_t z, int32_t *along, int32_t *len)
{
    if (z == b->z0 || z == b->z1 - 1) {
        *along = x - b->x0;
        *len = b->x1 - b->x0;
        return z == b->z0 ? 0 : 1;
    }
    *along = z - b->z0;
    *len = b->z1 - b->z0;
    return x == b->x0 ? 2 : 3;
}

/* Fills one voxel column of a building. */
static void building_column(const building *b, vwg_column *col, int32_t lx, int32_t lz, int32_t x, int32_t z, int32_t h)
{
    const int perimeter = x == b->x0 || x == b->x1 - 1 || z == b->z0 || z == b->z1 - 1;
    const int32_t mx = (b->x0 + b->x1) / 2, mz = (b->z0 + b->z1) / 2;
    const int inner = !perimeter && (x == mx || z == mz);
    const int corner = (x == b->x0 || x == b->x1 - 1) && (z == b->z0 || z == b->z1 - 1);
    int32_t along = 0, len = 0;
    int side = perimeter ? wall_side(b, x, z, &along, &len) : -1;
    /* Furniture stands one voxel inside the outer wall, never on an inner wall. */
    const int by_wall = !perimeter && !inner &&
                        (x == b->x0 + 1 || x == b->x1 - 2 || z == b->z0 + 1 || z == b->z1 - 2);
    const int32_t top = GROUND + b->floors * FLOOR;
    for (int32_t f = 0; f < b->floors; f++) {
        const int32_t y0 = GROUND + f * FLOOR;
        *vwg_at(col, lx, y0, lz) = VWG_CONCRETE; /* the slab (storey 0: the ground floor) */
        const uint64_t fh = vwn_mix(b->hash ^ ((uint64_t)(uint32_t)x << 40) ^ ((uint64_t)(uint32_t)z << 16) ^ (uint64_t)f);
        for (int32_t k = 1; k < FLOOR && y0 + k < h; k++) {
            uint8_t v = 0;
            if (perimeter) {
                v = VWG_BRICK;
                int door = f == 0 && side == b->door_side && k <= 3 && along >= len / 2 - 1 && along <= len / 2;
                int32_t t = along - 2;
                int window = !corner && !door && (k == 2 || k == 3) && along >= 2 && along <= len - 3 &&
                             t % b->win_pitch < b->win_width;
                if (door)
                    v = 0;
                else if (window)
                    v = b->glass ? VWG_GLASS : 0;
            } else if (inner) {
                /* Door gaps: one per half of each inner wall, three voxels high. */
                int32_t a = x == mx ? z : x, lo = x == mx ? b->z0 : b->x0, hi = x == mx ? b->z1 : b->x1;
                int32_t mid = x == mx ? mz : mx;
                int gap = k <= 3 && (a == (lo + mid) / 2 || a == (mid + hi) / 2);
                v = gap ? 0 : VWG_CONCRETE;
            } else if (by_wall && fh % 6 == 0 && k <= 1 + (int32_t)(fh >> 8 & 1)) {
                /* Keep the ground floor doorway free. */
                int near_door = f == 0 && (b->door_side < 2 ? (z == (b->door_side ? b->z1 - 2 : b->z0 + 1))
                                                             : (x == (b->door_side == 3 ? b->x1 - 2 : b->x0 + 1)));
                if (!near_door)
                    v = VWG_FURNITURE;
            }
            if (v)
                *vwg_at(col, lx, y0 + k, lz) = v;
        }
    }
    if (b->floors > 0 && top < h)
        *vwg_at(col, lx, top, lz) = VWG_ROOF;
}

static void fill(const void *state, void *scratch, vwg_column *col)
{
    (void)scratch;
    const city *c = state;
    for (int32_t lz = 0; lz < col->c; lz++)
        for (int32_t lx = 0; lx < col->c; lx++) {
            const int32_t x = col->x0 + lx, z = col->z0 + lz;
            const int32_t sx = x % BLOCK, sz = z % BLOCK;
            if (sx < STREET || sz < STREET) {
                /* Asphalt with a curb of concrete on both sides. */
                int curb = (sx < STREET && (sx == 0 || sx == STREET - 1)) || (sz < STREET && (sz == 0 || sz == STREET - 1));
                *vwg_at(col, lx, 0, lz) = curb ? VWG_CONCRETE : VWG_ASPHALT;
                continue;
            }
            *vwg_at(col, lx, 0, lz) = VWG_CONCRETE;
            building b;
            parcel(c, x, z, &b);
            if (b.floors > 0 && x >= b.x0 && x < b.x1 && z >= b.z0 && z < b.z1)
                building_column(&b, col, lx, lz, x, z, col->h);
        }
}

static void destroy(void *state) { free(state); }

uint64_t vwg_city_scratch_bytes(const int32_t size[3], int32_t chunk)
{
    (void)size;
    (void)chunk;
    return sizeof(city); /* buildings are computed per column, from the seed */
}

vw_status vwg_city_create(vw_world *w, uint64_t seed, vwg_generator *out, vw_error *err)
{
    city *c = calloc(1, sizeof *c);
    if (!c)
        return vwi_fail(err, VW_ERROR_OUT_OF_MEMORY, "city: out of memory");
    c->seed = vwn_mix(seed ^ 0xC17Cull);
    /* Storeys that fit under the top of the world with the roof. */
    c->max_floors = (w->size[1] - GROUND - 1) / FLOOR;
    if (c->max_floors < 0)
        c->max_floors = 0;
    vwg_set_palette(w);
    out->state = c;
    out->fill = fill;
    out->destroy = destroy;
    return VW_OK;
}
