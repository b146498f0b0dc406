/* query_sim.c — bots for `vis query --simulate`: players walking the streets of gen:city and
 * the corridors of gen:maze (any world works), turning at walls, stepping up single voxels,
 * peeking sideways now and then (a short strafe out and back, the move SMAC and S2FOW users
 * see players "teleport" on), and every edit_every ticks one bot cuts a 1x2 hole through the
 * wall it faces (a voxel edit that opens a line of sight). Deterministic: one splitmix64
 * stream from the seed. Bots are 0.6 x 1.8 x 0.6 voxels with the eye at 1.62 (Minecraft's
 * player), walking at 4.3 voxels per second, with latencies spread over 20..150 ms. */
#include "query_sim.h"

#include "json.h"

#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#define BOT_HALF 0.3
#define BOT_HEIGHT 1.8
#define BOT_EYE 1.62
#define BOT_SPEED 4.3
#define PEEK_SPEED 6.0
#define PEEK_TICKS 40

typedef struct bot {
    double x, z;
    int64_t y;           /* feet: the first air voxel above the ground                    */
    int dir;             /* 0 +x, 1 +z, 2 -x, 3 -z                                         */
    int peek;            /* ticks left in a peek (out, then back)                          */
    double vx, vz;
    double latency_ms;
} bot;

static uint64_t sm64(uint64_t *s)
{
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static double unit(uint64_t *s)
{
    return (double)(sm64(s) >> 11) * (1.0 / 9007199254740992.0);
}

static const int DX[4] = {1, 0, -1, 0}, DZ[4] = {0, 1, 0, -1};

static int solid(const vw_world *w, int64_t x, int64_t y, int64_t z)
{
    return vw_world_get(w, x, y, z) != 0;
}

/* Room for a bot with its feet at y and centre (x, z): air at y, y+1, ground at y-1 under
 * its centre. */
static int fits(const vw_world *w, double x, int64_t y, double z)
{
    for (int c = 0; c < 4; ++c) {
        int64_t vx = (int64_t)floor(x + ((c & 1) ? BOT_HALF : -BOT_HALF));
        int64_t vz = (int64_t)floor(z + ((c & 2) ? BOT_HALF : -BOT_HALF));
        if (solid(w, vx, y, vz) || solid(w, vx, y + 1, vz))
            return 0;
    }
    return solid(w, (int64_t)floor(x), y - 1, (int64_t)floor(z));
}

static int spawn(const vw_world *w, const vw_world_info *wi, uint64_t *rng, bot *b)
{
    for (int tries = 0; tries < 10000; ++tries) {
        double x = (double)wi->origin[0] + 1.0 + unit(rng) * (wi->size[0] - 2);
        double z = (double)wi->origin[2] + 1.0 + unit(rng) * (wi->size[2] - 2);
        for (int64_t y = wi->origin[1] + 1; y < wi->origin[1] + wi->size[1] - 2; ++y)
            if (fits(w, x, y, z)) {
                b->x = x;
                b->z = z;
                b->y = y;
                b->dir = (int)(sm64(rng) & 3);
                return 0;
            }
    }
    return -1;
}

static void step(const vw_world *w, uint64_t *rng, bot *b, double dt)
{
    double ox = b->x, oz = b->z;
    int d = b->dir;
    double speed = BOT_SPEED;
    if (b->peek > 0) {
        /* Out for the first half, back for the second, perpendicular to the walk. */
        int side = (d + 1) & 3;
        d = b->peek > PEEK_TICKS / 2 ? side : (side + 2) & 3;
        speed = PEEK_SPEED;
        --b->peek;
    } else if (sm64(rng) % 400 == 0) {
        b->peek = PEEK_TICKS;
    } else if (sm64(rng) % 200 == 0) {
        b->dir = (int)(sm64(rng) & 3);
    }
    double nx = b->x + DX[d] * speed * dt, nz = b->z + DZ[d] * speed * dt;
    if (fits(w, nx, b->y, nz)) {
        b->x = nx;
        b->z = nz;
    } else if (fits(w, nx, b->y + 1, nz)) {
        b->x = nx;
        b->z = nz;
        b->y += 1;
    } else if (fits(w, nx, b->y - 1, nz)) {
        b->x = nx;
        b->z = nz;
        b->y -= 1;
    } else if (b->peek == 0) {
        b->dir = (int)(sm64(rng) & 3);
    }
    b->vx = (b->x - ox) / dt;
    b->vz = (b->z - oz) / dt;
}

static int fail(char *err, size_t n, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, n, fmt, ap);
    va_end(ap);
    return -1;
}

int qs_simulate(vw_world *world, const qs_options *opt, FILE *f, char *err, size_t err_size)
{
    vw_world_info wi;
    vw_world_get_info(world, &wi);
    uint64_t rng = opt->seed * 0x2545F4914F6CDD1Dull + 1;
    double tick_ms = opt->tick_ms > 0.0 ? opt->tick_ms : 7.8125, dt = tick_ms * 1e-3;
    bot *bots = calloc(opt->players ? opt->players : 1, sizeof *bots);
    if (!bots)
        return fail(err, err_size, "out of memory for %u bots", opt->players);
    for (uint32_t i = 0; i < opt->players; ++i) {
        if (spawn(world, &wi, &rng, &bots[i]) != 0) {
            free(bots);
            return fail(err, err_size, "no room for a bot in this world (no 1x2 air column on the ground)");
        }
        bots[i].latency_ms = 20.0 + (double)((i * 37u) % 131u);
    }
    fprintf(f, "{\"replay\":\"libvis-query\",\"version\":1,\"scene\":");
    json_quoted(f, opt->scene ? opt->scene : "");
    fprintf(f, ",\"tick_ms\":%.6f}\n", tick_ms);
    for (uint32_t t = 0; t < opt->ticks; ++t) {
        for (uint32_t i = 0; i < opt->players; ++i)
            step(world, &rng, &bots[i], dt);
        fprintf(f, "{\"tick\":%u,\"viewers\":[", t);
        for (uint32_t i = 0; i < opt->players; ++i) {
            const bot *b = &bots[i];
            fprintf(f, "%s{\"id\":%u,\"eye\":[%.4f,%.4f,%.4f],\"dir\":[%d,0,%d],\"fov\":90,\"vel\":[%.4f,0,%.4f],"
                       "\"latency_ms\":%.1f}",
                    i ? "," : "", i + 1, b->x, (double)b->y + BOT_EYE, b->z, DX[b->dir], DZ[b->dir], b->vx, b->vz,
                    b->latency_ms);
        }
        fprintf(f, "],\"entities\":[");
        for (uint32_t i = 0; i < opt->players; ++i) {
            const bot *b = &bots[i];
            fprintf(f, "%s{\"id\":%u,\"min\":[%.4f,%.4f,%.4f],\"max\":[%.4f,%.4f,%.4f],\"vel\":[%.4f,0,%.4f]}",
                    i ? "," : "", i + 1, b->x - BOT_HALF, (double)b->y, b->z - BOT_HALF, b->x + BOT_HALF,
                    (double)b->y + BOT_HEIGHT, b->z + BOT_HALF, b->vx, b->vz);
        }
        fprintf(f, "]");
        if (opt->edit_every && opt->players && t % opt->edit_every == opt->edit_every - 1) {
            /* The bot whose turn it is cuts a hole through the first wall it faces within
             * 12 voxels: 1 wide, 2 high, up to 3 deep. */
            const bot *b = &bots[(t / opt->edit_every) % opt->players];
            int n = 0;
            fprintf(f, ",\"edits\":[");
            for (int k = 1; k <= 12 && n == 0; ++k) {
                int64_t x = (int64_t)floor(b->x) + DX[b->dir] * k, z = (int64_t)floor(b->z) + DZ[b->dir] * k;
                if (!solid(world, x, b->y, z) && !solid(world, x, b->y + 1, z))
                    continue;
                for (int depth = 0; depth < 3; ++depth) {
                    int64_t hx = x + DX[b->dir] * depth, hz = z + DZ[b->dir] * depth;
                    for (int64_t y = b->y; y <= b->y + 1; ++y)
                        if (solid(world, hx, y, hz) && vw_world_set(world, hx, y, hz, 0) == VW_OK) {
                            fprintf(f, "%s[%lld,%lld,%lld,0]", n ? "," : "", (long long)hx, (long long)y,
                                    (long long)hz);
                            ++n;
                        }
                }
            }
            fprintf(f, "]");
        }
        fprintf(f, "}\n");
    }
    free(bots);
    if (ferror(f))
        return fail(err, err_size, "write error");
    return 0;
}
