/* gen_maze.c — a maze of 1-voxel walls and 1-3 voxel corridors on a floor.
 *
 * Wall lines run along both horizontal axes at uneven spacing (each corridor 1, 2 or 3 voxels
 * wide, chosen per line by the seed); the cells between them form a grid graph, carved into a
 * perfect maze by a randomised depth-first search (the "recursive backtracker", e.g. Jamis
 * Buck, "Mazes for Programmers", 2015), with an explicit stack so size never threatens the C
 * stack. A few extra walls are then opened so that the maze has loops, and the outer wall
 * gets an entrance and an exit. Posts where wall lines cross always stay, so every 4x4
 * window of the plan holds wall: corridors can never be wider than 3. */
#include <stdlib.h>
#include <string.h>

#include "generators.h"
#include "noise.h"

#define WALL_TOP 5            /* walls occupy y = 1..WALL_TOP (fewer in a low world)        */
#define MAX_CELLS (1u << 28)  /* a maze this big is beyond any sensible use               */

typedef struct maze {
    int32_t n[2];             /* cells along x, z                                           */
    int32_t *line[2];         /* per voxel coordinate: wall line index, or -1 in a corridor */
    int32_t *cell[2];         /* per voxel coordinate: cell index (valid in corridors)       */
    uint8_t *open;            /* per cell: bit 0 = open towards +x, bit 1 = towards +z      */
    int32_t wall_top;
    int32_t size[2];          /* voxels along x, z                                          */
} maze;

/* Lays out wall lines along one axis of `size` voxels: the first at 0, the last at size-1,
 * corridors of 1..3 between. Returns the number of cells. */
static int32_t layout_axis(int32_t size, uint64_t seed, int32_t *line, int32_t *cell)
{
    int32_t pos = 0, lines = 0, cells = 0;
    const int32_t end = size - 1;
    line[0] = lines++;
    cell[0] = -1;
    while (pos < end) {
        int32_t room = end - pos - 1; /* voxels between this line and the final one */
        int32_t w;
        if (room <= 3) {
            w = room;
        } else {
            w = 1 + (int32_t)(vwn_mix(seed ^ (uint64_t)pos) % 3);
            if (w > room - 2)
                w = room - 2; /* leave at least one corridor voxel before the final line */
        }
        for (int32_t i = 1; i <= w; i++) {
            line[pos + i] = -1;
            cell[pos + i] = cells;
        }
        if (w > 0)
            cells++;
        pos += w + 1;
        line[pos] = lines++;
        cell[pos] = -1;
    }
    return cells;
}

static void carve(maze *m, uint64_t seed, uint32_t *stack, uint8_t *seen)
{
    const int32_t nx = m->n[0], nz = m->n[1];
    size_t top = 0;
    uint64_t rng = seed;
    stack[top++] = 0;
    seen[0] = 1;
    while (top) {
        const uint32_t c = stack[top - 1];
        const int32_t x = (int32_t)(c % (uint32_t)nx), z = (int32_t)(c / (uint32_t)nx);
        int32_t options[4], k = 0;
        if (x > 0 && !seen[c - 1]) options[k++] = 0;
        if (x + 1 < nx && !seen[c + 1]) options[k++] = 1;
        if (z > 0 && !seen[c - (uint32_t)nx]) options[k++] = 2;
        if (z + 1 < nz && !seen[c + (uint32_t)nx]) options[k++] = 3;
        if (!k) {
            top--;
            continue;
        }
        rng = vwn_mix(rng);
        uint32_t next;
        switch (options[rng % (uint64_t)k]) {
        case 0: next = c - 1; m->open[next] |= 1; break;
        case 1: next = c + 1; m->open[c] |= 1; break;
        case 2: next = c - (uint32_t)nx; m->open[next] |= 2; break;
        default: next = c + (uint32_t)nx; m->open[c] |= 2; break;
        }
        seen[next] = 1;
        stack[top++] = next;
    }
    /* Loops: open about one wall in twenty more. */
    for (uint32_t c = 0; c < (uint32_t)nx * (uint32_t)nz; c++) {
        uint64_t h = vwn_mix(seed ^ 0xA5A5A5A5ull ^ ((uint64_t)c << 8));
        if (h % 20 == 0 && (int32_t)(c % (uint32_t)nx) + 1 < nx)
            m->open[c] |= 1;
        if ((h >> 8) % 20 == 0 && (int32_t)(c / (uint32_t)nx) + 1 < nz)
            m->open[c] |= 2;
    }
}

/* Is the voxel column (x, z) wall? Lines are never adjacent (layout_axis leaves a corridor
 * between any two), so the voxels beside a wall segment are corridor cells. */
static int is_wall(const maze *m, int32_t x, int32_t z, int32_t sx, int32_t sz)
{
    const int32_t lx = m->line[0][x], lz = m->line[1][z];
    if (lx >= 0 && lz >= 0)
        return 1;                                  /* a post                               */
    if (lx < 0 && lz < 0)
        return 0;                                  /* a corridor                           */
    if (lx >= 0) {                                 /* a segment between two x-neighbours   */
        const int32_t cz = m->cell[1][z];
        if (x == 0)
            return cz != 0;                        /* the entrance                         */
        if (x == sx - 1)
            return cz != m->n[1] - 1;              /* the exit                             */
        const uint32_t left = (uint32_t)m->cell[0][x - 1];
        return !(m->open[left + (uint32_t)m->n[0] * (uint32_t)cz] & 1);
    }
    if (z == 0 || z == sz - 1)                     /* a segment between two z-neighbours   */
        return 1;
    const uint32_t below = (uint32_t)m->cell[1][z - 1];
    return !(m->open[(uint32_t)m->cell[0][x] + (uint32_t)m->n[0] * below] & 2);
}

static void fill(const void *state, void *scratch, vwg_column *col)
{
    (void)scratch;
    const maze *m = state;
    for (int32_t z = 0; z < col->c; z++)
        for (int32_t x = 0; x < col->c; x++) {
            *vwg_at(col, x, 0, z) = VWG_MAZE_FLOOR;
            if (!is_wall(m, col->x0 + x, col->z0 + z, m->size[0], m->size[1]))
                continue;
            for (int32_t y = 1; y <= m->wall_top; y++)
                *vwg_at(col, x, y, z) = VWG_MAZE_WALL;
        }
}

static void destroy(void *state)
{
    maze *m = state;
    if (!m)
        return;
    for (int a = 0; a < 2; a++) {
        free(m->line[a]);
        free(m->cell[a]);
    }
    free(m->open);
    free(m);
}

/* At its peak (while carving): the axis layouts (line and cell, int32 per voxel of x and z)
 * and, per cell, open (1 byte, kept), the carving stack (4) and seen (1). layout_axis gives
 * each cell at least one corridor voxel and one wall line, so at most size/2 + 1 cells lie
 * along an axis. */
uint64_t vwg_maze_scratch_bytes(const int32_t size[3], int32_t chunk)
{
    (void)chunk;
    const uint64_t cells = (uint64_t)(size[0] / 2 + 1) * (uint64_t)(size[2] / 2 + 1);
    return sizeof(maze) + 2 * sizeof(int32_t) * ((uint64_t)size[0] + (uint64_t)size[2]) +
           cells * (1 + sizeof(uint32_t) + 1);
}

vw_status vwg_maze_create(vw_world *w, uint64_t seed, vwg_generator *out, vw_error *err)
{
    const int32_t sx = w->size[0], sz = w->size[2];
    if ((uint64_t)(sx / 2 + 1) * (uint64_t)(sz / 2 + 1) > MAX_CELLS)
        return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "maze: %dx%d voxels is over the generator's limit of 2^28 cells",
                        (int)sx, (int)sz);
    maze *m = calloc(1, sizeof *m);
    if (!m)
        return vwi_fail(err, VW_ERROR_OUT_OF_MEMORY, "maze: out of memory");
    const int32_t size[2] = {sx, sz};
    m->size[0] = sx;
    m->size[1] = sz;
    for (int a = 0; a < 2; a++) {
        m->line[a] = malloc(sizeof(int32_t) * (size_t)size[a]);
        m->cell[a] = malloc(sizeof(int32_t) * (size_t)size[a]);
        if (!m->line[a] || !m->cell[a]) {
            destroy(m);
            return vwi_fail(err, VW_ERROR_OUT_OF_MEMORY, "maze: out of memory");
        }
        m->n[a] = layout_axis(size[a], vwn_mix(seed + 0x51ull * (uint64_t)(a + 1)), m->line[a], m->cell[a]);
    }
    m->wall_top = w->size[1] - 1 < WALL_TOP ? w->size[1] - 1 : WALL_TOP;
    const size_t cells = (size_t)m->n[0] * (size_t)m->n[1];
    m->open = calloc(cells ? cells : 1, 1);
    uint32_t *stack = malloc(sizeof(uint32_t) * (cells ? cells : 1));
    uint8_t *seen = calloc(cells ? cells : 1, 1);
    if (!m->open || !stack || !seen) {
        free(stack);
        free(seen);
        destroy(m);
        return vwi_fail(err, VW_ERROR_OUT_OF_MEMORY, "maze: out of memory for %zu cells", cells);
    }
    if (cells)
        carve(m, vwn_mix(seed ^ 0xC0FFEEull), stack, seen);
    free(stack);
    free(seen);
    vwg_set_palette(w);
    out->state = m;
    out->fill = fill;
    out->destroy = destroy;
    return VW_OK;
}
