/* spec.c — turns a world SPEC into a world: "gen:NAME[:key=value]..." runs a generator
 * (through the driver in gen_run.c), a path ending in .vox or .vdb (with an optional
 * "?key=value&..." query) calls an importer.
 *
 * Budget (vw_budget): a generator's box is checked against max_voxels, and its chunk table
 * plus its scratch (the generator's state, and per worker a column buffer and the
 * generator's worker scratch) against max_bytes, before anything is allocated; while it
 * runs, the world's limit is lowered by the scratch, so the whole load stays within
 * max_bytes. More threads than the budget has scratch for are not used (the world is the
 * same for any count). Importers get the budget as is. */
#include <ctype.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "generators.h"
#include "parallel.h"

#define DEFAULT_SPEC "gen:terrain:size=512x128x512:seed=1"
#define MAX_GEN_CHUNKS (1ull << 24)

const char *vw_default_spec(void) { return DEFAULT_SPEC; }

/* ---- palette ------------------------------------------------------------------------ */

void vwg_set_palette(vw_world *w)
{
    static const struct { uint8_t index; uint32_t rgba, flags; } table[] = {
        {VWG_GRASS, 0xFF3C9E4Bu, VW_MAT_OPAQUE},
        {VWG_DIRT, 0xFF2D5A86u, VW_MAT_OPAQUE},
        {VWG_STONE, 0xFF808080u, VW_MAT_OPAQUE},
        {VWG_SAND, 0xFF8CD2E6u, VW_MAT_OPAQUE},
        {VWG_WATER, 0x99C07030u, VW_MAT_SEE_THROUGH | VW_MAT_REFLECTIVE},
        {VWG_BEDROCK, 0xFF303030u, VW_MAT_OPAQUE},
        {VWG_SNOW, 0xFFFAFAFAu, VW_MAT_OPAQUE},
        {VWG_ASPHALT, 0xFF3A3A3Au, VW_MAT_OPAQUE},
        {VWG_CONCRETE, 0xFFB4B4B4u, VW_MAT_OPAQUE},
        {VWG_BRICK, 0xFF3048A8u, VW_MAT_OPAQUE},
        {VWG_GLASS, 0x60F0E0C0u, VW_MAT_SEE_THROUGH | VW_MAT_REFLECTIVE},
        {VWG_WOOD, 0xFF2A5C8Cu, VW_MAT_OPAQUE},
        {VWG_ROOF, 0xFF404070u, VW_MAT_OPAQUE},
        {VWG_FURNITURE, 0xFF1E90C8u, VW_MAT_OPAQUE},
        {VWG_MAZE_WALL, 0xFF7A6A5Au, VW_MAT_OPAQUE},
        {VWG_MAZE_FLOOR, 0xFF506050u, VW_MAT_OPAQUE},
        {VWG_LEAVES, 0xC03A8B2Eu, VW_MAT_SEE_THROUGH},
    };
    for (size_t i = 0; i < sizeof table / sizeof table[0]; i++) {
        vw_material m = {table[i].rgba, table[i].flags};
        vw_world_set_material(w, table[i].index, &m);
    }
}

/* ---- parsing ------------------------------------------------------------------------ */

/* Parses a decimal integer that must fill [s, end) exactly. */
static int parse_i64(const char *s, const char *end, int64_t *out)
{
    char buf[32];
    size_t n = (size_t)(end - s);
    if (n == 0 || n >= sizeof buf)
        return 0;
    memcpy(buf, s, n);
    buf[n] = '\0';
    if (!(isdigit((unsigned char)buf[0]) || ((buf[0] == '-' || buf[0] == '+') && isdigit((unsigned char)buf[1]))))
        return 0;
    char *e;
    errno = 0;
    long long v = strtoll(buf, &e, 10);
    if (errno || *e)
        return 0;
    *out = v;
    return 1;
}

/* Parses "A<sep>B<sep>C" into three integers. */
static int parse_triple(const char *s, const char *end, char sep, int64_t out[3])
{
    for (int i = 0; i < 3; i++) {
        const char *p = s;
        while (p < end && *p != sep)
            p++;
        if ((i < 2) != (p < end))
            return 0;
        if (!parse_i64(s, p, &out[i]))
            return 0;
        s = p + 1;
    }
    return 1;
}

typedef struct gen_spec {
    char name[16];
    int have_size;
    int64_t size[3];
    uint64_t seed;
    int32_t chunk;
    int64_t origin[3];
    int32_t trees;           /* terrain: percent of 8x8 cells with a tree */
} gen_spec;

static vw_status parse_gen(const char *spec, gen_spec *g, vw_error *err)
{
    const char *p = spec + 4; /* after "gen:" */
    const char *end = p + strcspn(p, ":");
    size_t n = (size_t)(end - p);
    memset(g, 0, sizeof *g);
    g->seed = 1;
    g->chunk = 16;
    if (n == 0 || n >= sizeof g->name)
        return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': missing or unknown generator name (terrain, city, maze, default, large)", spec);
    memcpy(g->name, p, n);
    int large = 0;
    if (strcmp(g->name, "default") == 0) {
        strcpy(g->name, "terrain");
    } else if (strcmp(g->name, "large") == 0) {
        strcpy(g->name, "terrain");
        large = 1;
    } else if (strcmp(g->name, "terrain") && strcmp(g->name, "city") && strcmp(g->name, "maze")) {
        return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': unknown generator '%s' (terrain, city, maze, default, large)", spec, g->name);
    }
    p = end;
    while (*p == ':') {
        const char *key = p + 1;
        const char *stop = key + strcspn(key, ":");
        const char *eq = memchr(key, '=', (size_t)(stop - key));
        if (!eq)
            return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': expected key=value, got '%.*s'", spec, (int)(stop - key), key);
        const char *val = eq + 1;
        size_t klen = (size_t)(eq - key);
#define KEY(s) (klen == sizeof(s) - 1 && memcmp(key, s, klen) == 0)
        if (KEY("size")) {
            if (!parse_triple(val, stop, 'x', g->size))
                return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': size '%.*s' is not XxYxZ (voxels)", spec, (int)(stop - val), val);
            for (int a = 0; a < 3; a++)
                if (g->size[a] < 1 || g->size[a] > VWI_MAX_AXIS)
                    return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': size %lld on axis %c is outside 1..%d voxels",
                                    spec, (long long)g->size[a], "xyz"[a], VWI_MAX_AXIS);
            g->have_size = 1;
        } else if (KEY("seed")) {
            int64_t s;
            if (!parse_i64(val, stop, &s) || s < 0)
                return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': seed '%.*s' is not a non-negative integer", spec, (int)(stop - val), val);
            g->seed = (uint64_t)s;
        } else if (KEY("chunk")) {
            int64_t c;
            if (!parse_i64(val, stop, &c) || (c != 16 && c != 32))
                return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': chunk '%.*s' must be 16 or 32", spec, (int)(stop - val), val);
            g->chunk = (int32_t)c;
        } else if (KEY("origin")) {
            if (!parse_triple(val, stop, ',', g->origin))
                return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': origin '%.*s' is not X,Y,Z (voxels)", spec, (int)(stop - val), val);
            for (int a = 0; a < 3; a++)
                if (g->origin[a] < -VWI_MAX_ORIGIN || g->origin[a] > VWI_MAX_ORIGIN)
                    return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': origin %lld is beyond +-2^60", spec, (long long)g->origin[a]);
        } else if (KEY("trees")) {
            int64_t tr;
            if (strcmp(g->name, "terrain") != 0)
                return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': trees are a terrain key (%s has none)", spec, g->name);
            if (!parse_i64(val, stop, &tr) || tr < 0 || tr > 100)
                return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': trees '%.*s' is not a percentage 0..100", spec,
                                (int)(stop - val), val);
            g->trees = (int32_t)tr;
        } else if (KEY("preset")) {
            if ((size_t)(stop - val) == 5 && memcmp(val, "large", 5) == 0 && strcmp(g->name, "terrain") == 0)
                large = 1;
            else if (!((size_t)(stop - val) == 7 && memcmp(val, "default", 7) == 0))
                return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': unknown preset '%.*s' for %s (terrain has: default, large)",
                                spec, (int)(stop - val), val, g->name);
        } else {
            return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': unknown key '%.*s' (size, seed, chunk, origin, preset, trees)",
                            spec, (int)klen, key);
        }
#undef KEY
        p = stop;
    }
    if (*p)
        return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': trailing text '%s'", spec, p);
    if (!g->have_size) {
        /* Default sizes; the large preset is the scale of the original CUDA system: over
         * 100,000 chunks with a non-empty mesh. */
        static const int64_t terrain_size[3] = {512, 128, 512}, large_size[3] = {2560, 160, 2560},
                             city_size[3] = {512, 128, 512}, maze_size[3] = {256, 16, 256};
        const int64_t *d = large ? large_size : strcmp(g->name, "city") == 0 ? city_size
                                              : strcmp(g->name, "maze") == 0 ? maze_size : terrain_size;
        memcpy(g->size, d, sizeof g->size);
    }
    /* Origins round down to a chunk multiple (floor, also for negative values). */
    for (int a = 0; a < 3; a++) {
        int64_t r = g->origin[a] % g->chunk;
        g->origin[a] -= r < 0 ? r + g->chunk : r;
    }
    return VW_OK;
}

/* Creates the world and runs the generator on it with `threads` workers whose scratch
 * (`scratch` bytes in all, the generator's state included) is charged to the world's limit
 * while they run. On failure *out may hold the partial world, for the message; the caller
 * destroys it. */
static vw_status generate(const vw_world_desc *d, const gen_spec *g, int terrain, uint32_t threads, uint64_t scratch,
                          vwg_progress *prog, vw_world **out, vw_error *err)
{
    vw_world *w;
    vw_status st = vw_world_create(d, &w, err);
    if (st != VW_OK)
        return st;
    *out = w;
    vwg_generator gen;
    memset(&gen, 0, sizeof gen);
    if (terrain)
        st = vwg_terrain_create(w, g->seed, g->trees, &gen, err);
    else if (strcmp(g->name, "city") == 0)
        st = vwg_city_create(w, g->seed, &gen, err);
    else
        st = vwg_maze_create(w, g->seed, &gen, err);
    if (st != VW_OK)
        return st;
    if (err)
        err->message[0] = '\0';
    w->max_bytes = d->max_bytes - scratch; /* the scratch lives as long as the run */
    st = vwg_run(w, &gen, threads, prog, err);
    w->max_bytes = d->max_bytes;
    gen.destroy(gen.state);
    return st;
}

static vw_status from_gen(const char *spec, const vw_budget *budget, uint32_t threads, vw_progress_fn progress, void *user,
                          vw_world **out, vw_error *err)
{
    gen_spec g;
    vw_status st = parse_gen(spec, &g, err);
    if (st != VW_OK)
        return st;
    /* Generating visits every chunk; past 2^24 chunks (64 times the large preset) a spec is
     * far more likely a typo than a wish to wait hours. */
    const uint64_t chunks = (uint64_t)((g.size[0] + g.chunk - 1) / g.chunk) * (uint64_t)((g.size[1] + g.chunk - 1) / g.chunk) *
                            (uint64_t)((g.size[2] + g.chunk - 1) / g.chunk);
    if (chunks > MAX_GEN_CHUNKS)
        return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': %llu chunks is over the generators' limit of %llu",
                        spec, (unsigned long long)chunks, (unsigned long long)MAX_GEN_CHUNKS);
    /* The budget, before anything is allocated: every voxel of the box is generated (sizes
     * round up to chunks), and the table and the scratch exist before the first chunk. */
    const vw_budget b = vwi_budget(budget);
    int32_t size[3];
    uint64_t voxels = 1;
    for (int a = 0; a < 3; a++) {
        size[a] = (int32_t)((g.size[a] + g.chunk - 1) / g.chunk * g.chunk);
        voxels *= (uint64_t)size[a];
    }
    char n1[32], n2[32], b1[32], b2[32], b3[32];
    if (voxels > b.max_voxels)
        return vwi_fail(err, VW_ERROR_BUDGET, "spec '%s': %dx%dx%d is %s voxels; the budget is %s voxels", spec, size[0],
                        size[1], size[2], vwi_format_count(voxels, n1, sizeof n1),
                        vwi_format_count(b.max_voxels, n2, sizeof n2));
    const int terrain = strcmp(g.name, "terrain") == 0;
    const uint64_t state = terrain ? vwg_terrain_scratch_bytes(size, g.chunk)
                         : strcmp(g.name, "city") == 0 ? vwg_city_scratch_bytes(size, g.chunk)
                                                       : vwg_maze_scratch_bytes(size, g.chunk);
    const uint64_t column = vwg_column_bytes(g.chunk, size[1]);
    const uint64_t worker = terrain ? vwg_terrain_worker_bytes(size, g.chunk) : 0;
    const uint64_t table = vwi_table_bytes(chunks);
    /* One worker must fit; more only while their scratch does too. */
    const uint64_t columns = (uint64_t)(size[0] / g.chunk) * (uint64_t)(size[2] / g.chunk);
    threads = vwi_threads_for(threads, columns);
    while (threads > 1 && table + state + threads * vwg_run_stride(column, worker, threads) > b.max_bytes)
        threads--;
    uint64_t scratch = state + threads * vwg_run_stride(column, worker, threads);
    if (table + scratch > b.max_bytes)
        return vwi_fail(err, VW_ERROR_BUDGET,
                        "spec '%s': the table of %s chunks (%s) and the generator's scratch (%s) need %s; the budget is %s",
                        spec, vwi_format_count(chunks, n1, sizeof n1), vwi_format_bytes(table, b1, sizeof b1),
                        vwi_format_bytes(scratch, b2, sizeof b2), vwi_format_bytes(table + scratch, b3, sizeof b3),
                        vwi_format_bytes(b.max_bytes, n2, sizeof n2));
    vw_world_desc d;
    memset(&d, 0, sizeof d);
    d.chunk_size = g.chunk;
    d.max_bytes = b.max_bytes;
    for (int a = 0; a < 3; a++) {
        d.origin[a] = g.origin[a];
        d.size[a] = (int32_t)g.size[a];
    }
    vwg_progress prog = {progress, user, -1};
    vw_world *w = NULL;
    st = generate(&d, &g, terrain, threads, scratch, &prog, &w, err);
    if (st == VW_ERROR_BUDGET && threads > 1) {
        /* The extra workers' scratch may have taken room the world needed: a serial run
         * decides, so that no thread count changes whether a spec loads. (Progress goes on
         * from where it was: the serial run reports only what lies beyond it.) */
        vw_world_destroy(w);
        w = NULL;
        threads = 1;
        scratch = state + vwg_run_stride(column, worker, 1);
        st = generate(&d, &g, terrain, threads, scratch, &prog, &w, err);
    }
    if (st != VW_OK && w && (!err || !err->message[0])) {
        const uint64_t held = vwi_world_bytes(w);
        if (st == VW_ERROR_BUDGET)
            vwi_fail(err, st,
                     "spec '%s': the world outgrew the budget of %s while generating: %s chunks hold data "
                     "(%s in all) beside %s of the generator's scratch",
                     spec, vwi_format_bytes(b.max_bytes, b1, sizeof b1), vwi_format_count(w->dense_chunks, n1, sizeof n1),
                     vwi_format_bytes(held, b2, sizeof b2), vwi_format_bytes(scratch, b3, sizeof b3));
        else
            vwi_fail(err, st, "spec '%s': out of memory while generating (%s chunks hold data so far, %s)", spec,
                     vwi_format_count(w->dense_chunks, n1, sizeof n1), vwi_format_bytes(held, b2, sizeof b2));
    }
    if (st != VW_OK) {
        vw_world_destroy(w);
        return st;
    }
    vw_world_clear_dirty(w); /* setting materials marks nothing on an empty world, but be sure */
    *out = w;
    return VW_OK;
}

/* ---- files -------------------------------------------------------------------------- */

/* Case-insensitive: "MAP.VOX" is a .vox file too. */
static int ends_with(const char *s, size_t n, const char *suffix)
{
    size_t k = strlen(suffix);
    if (n < k)
        return 0;
    for (size_t i = 0; i < k; i++)
        if (tolower((unsigned char)s[n - k + i]) != tolower((unsigned char)suffix[i]))
            return 0;
    return 1;
}

static vw_status from_file(const char *spec, const vw_budget *budget, vw_progress_fn progress, void *user, vw_world **out,
                           vw_error *err)
{
    /* "path?key=value&key=value": the query starts at the last '?' that follows the
     * extension, so paths with '?' elsewhere still work. */
    size_t len = strlen(spec);
    const char *q = strrchr(spec, '?');
    size_t plen = q ? (size_t)(q - spec) : len;
    if (q && !(ends_with(spec, plen, ".vox") || ends_with(spec, plen, ".vdb"))) {
        q = NULL;
        plen = len;
    }
    int vox = ends_with(spec, plen, ".vox"), vdb = ends_with(spec, plen, ".vdb");
    if (!vox && !vdb)
        return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT,
                        "spec '%s': not a generator (gen:NAME[:key=value]...) nor a .vox or .vdb file", spec);
    /* One copy holds the path, a NUL, then the query (split in place at '&' and '='). */
    char *path = malloc(len + 2);
    if (!path)
        return vwi_fail(err, VW_ERROR_OUT_OF_MEMORY, "out of memory");
    memcpy(path, spec, plen);
    path[plen] = '\0';
    char *query = q ? strcpy(path + plen + 1, q + 1) : NULL;
    vw_vdb_options vo;
    memset(&vo, 0, sizeof vo);
    if (budget)
        vo.budget = *budget;
    vw_status st = VW_OK;
    for (char *kv = query; kv && st == VW_OK;) {
        char *amp = strchr(kv, '&');
        if (amp)
            *amp = '\0';
        char *eq = strchr(kv, '=');
        char *val = eq ? eq + 1 : NULL;
        if (eq)
            *eq = '\0';
        int64_t iv = 0;
        char *e = NULL;
        if (!val) {
            st = vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': expected key=value in the query, got '%s'", spec, kv);
        } else if (strcmp(kv, "chunk") == 0) {
            if (!parse_i64(val, val + strlen(val), &iv) || (iv != 16 && iv != 32))
                st = vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': chunk '%s' must be 16 or 32", spec, val);
            vo.chunk_size = (int32_t)iv;
        } else if (vdb && strcmp(kv, "grid") == 0) {
            vo.grid = val;
        } else if (vdb && strcmp(kv, "threshold") == 0) {
            errno = 0;
            vo.fog_threshold = strtof(val, &e);
            if (errno || e == val || *e)
                st = vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': threshold '%s' is not a number", spec, val);
        } else if (vdb && strcmp(kv, "transform") == 0) {
            if (!parse_i64(val, val + strlen(val), &iv) || (iv != 0 && iv != 1))
                st = vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': transform '%s' must be 0 or 1", spec, val);
            vo.use_transform = (int)iv;
        } else {
            st = vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "spec '%s': unknown query key '%s' (%s)", spec, kv,
                          vdb ? "chunk, grid, threshold, transform" : "chunk");
        }
        kv = amp ? amp + 1 : NULL;
    }
    if (st == VW_OK) {
        if (progress)
            progress("loading", 0.0, user);
        st = vox ? vw_vox_load_file(path, vo.chunk_size, budget, out, err) : vw_vdb_load_file(path, &vo, out, err);
        if (st == VW_OK) {
            vw_world_clear_dirty(*out);
            if (progress)
                progress("loading", 1.0, user);
        }
    }
    free(path);
    return st;
}

vw_status vw_world_load(const char *spec, const vw_load_options *options, vw_world **out_world, vw_error *err)
{
    if (!spec || !out_world)
        return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "vw_world_load: spec and out_world must not be NULL");
    *out_world = NULL;
    vw_load_options o;
    memset(&o, 0, sizeof o);
    if (options)
        o = *options;
    if (strncmp(spec, "gen:", 4) == 0)
        return from_gen(spec, &o.budget, o.threads, o.progress, o.progress_user, out_world, err);
    return from_file(spec, &o.budget, o.progress, o.progress_user, out_world, err);
}

vw_status vw_world_from_spec(const char *spec, const vw_budget *budget, vw_progress_fn progress, void *progress_user, vw_world **out_world, vw_error *err)
{
    if (!spec || !out_world)
        return vwi_fail(err, VW_ERROR_INVALID_ARGUMENT, "vw_world_from_spec: spec and out_world must not be NULL");
    vw_load_options o;
    memset(&o, 0, sizeof o);
    if (budget)
        o.budget = *budget;
    o.progress = progress;
    o.progress_user = progress_user;
    return vw_world_load(spec, &o, out_world, err);
}
