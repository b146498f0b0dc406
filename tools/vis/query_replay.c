/* query_replay.c — reads `vis query` replays with Jansson (a well-kept parser from Debian,
 * DESIGN.md "Server queries"; never a hand-written one). Every value is checked before use:
 * types, finiteness, ranges, ID ranges, array lengths against the budgets given at open; a
 * size read from the file is never used to allocate. Lines are read into a fixed buffer:
 * a line longer than QR_MAX_LINE_BYTES is an error, as is a line cut short (no newline and
 * not valid JSON). Duplicate keys are rejected (JSON_REJECT_DUPLICATES). */
#ifdef VIS_HAVE_JANSSON
#include "query_replay.h"

#include <errno.h>
#include <jansson.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

struct qr_reader {
    FILE *f;
    char *line;
    uint64_t line_no;
    uint32_t max_viewers, max_entities;
    int64_t wmin[3], wmax[3];
    vis_query_viewer *viewers;
    vis_query_entity *entities;
    qr_edit *edits;
    qr_header header;
    int header_checked;
};

static int fail(char *err, size_t n, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, n, fmt, ap);
    va_end(ap);
    return -1;
}

qr_reader *qr_open(const char *path, uint32_t max_viewers, uint32_t max_entities, const int64_t world_min[3],
                   const int64_t world_max[3], char *err, size_t err_size)
{
    qr_reader *r = calloc(1, sizeof *r);
    if (!r) {
        fail(err, err_size, "out of memory");
        return NULL;
    }
    r->max_viewers = max_viewers;
    r->max_entities = max_entities;
    memcpy(r->wmin, world_min, sizeof r->wmin);
    memcpy(r->wmax, world_max, sizeof r->wmax);
    r->line = malloc(QR_MAX_LINE_BYTES + 2);
    r->viewers = calloc(max_viewers ? max_viewers : 1, sizeof *r->viewers);
    r->entities = calloc(max_entities ? max_entities : 1, sizeof *r->entities);
    r->edits = calloc(QR_MAX_EDITS, sizeof *r->edits);
    r->f = fopen(path, "rb");
    if (!r->line || !r->viewers || !r->entities || !r->edits || !r->f) {
        fail(err, err_size, r->f ? "out of memory" : "cannot open '%s'", path);
        qr_close(r);
        return NULL;
    }
    return r;
}

void qr_close(qr_reader *r)
{
    if (!r)
        return;
    if (r->f)
        fclose(r->f);
    free(r->line);
    free(r->viewers);
    free(r->entities);
    free(r->edits);
    free(r);
}

const qr_header *qr_get_header(const qr_reader *r)
{
    return &r->header;
}

/* One line into r->line: 1, 0 at end of file, -1 too long, -2 a read error (errno).
 * *len excludes the newline. */
static int read_line(qr_reader *r, size_t *len, int *had_newline)
{
    size_t n = 0;
    int c;
    *had_newline = 0;
    while ((c = fgetc(r->f)) != EOF) {
        if (c == '\n') {
            *had_newline = 1;
            break;
        }
        if (n == QR_MAX_LINE_BYTES)
            return -1;
        r->line[n++] = (char)c;
    }
    if (c == EOF && ferror(r->f))
        return -2; /* a directory, a device that failed: not an empty replay */
    if (n == 0 && c == EOF)
        return 0;
    *len = n;
    ++r->line_no;
    return 1;
}

static int get_vec3(json_t *obj, const char *key, int required, double lo, double hi, double out[3], char *why,
                    size_t wn)
{
    json_t *a = json_object_get(obj, key);
    if (!a) {
        if (required)
            return fail(why, wn, "'%s' is missing", key);
        out[0] = out[1] = out[2] = 0.0;
        return 0;
    }
    if (!json_is_array(a) || json_array_size(a) != 3)
        return fail(why, wn, "'%s' must be an array of 3 numbers", key);
    for (size_t i = 0; i < 3; ++i) {
        json_t *x = json_array_get(a, i);
        if (!json_is_number(x))
            return fail(why, wn, "'%s'[%zu] is not a number", key, i);
        double v = json_number_value(x);
        if (!isfinite(v) || v < lo || v > hi)
            return fail(why, wn, "'%s'[%zu] = %g is outside [%g, %g]", key, i, v, lo, hi);
        out[i] = v;
    }
    return 0;
}

static int get_number(json_t *obj, const char *key, int required, double dflt, double lo, double hi, double *out,
                      char *why, size_t wn)
{
    json_t *x = json_object_get(obj, key);
    if (!x) {
        if (required)
            return fail(why, wn, "'%s' is missing", key);
        *out = dflt;
        return 0;
    }
    if (!json_is_number(x))
        return fail(why, wn, "'%s' is not a number", key);
    double v = json_number_value(x);
    if (!isfinite(v) || v < lo || v > hi)
        return fail(why, wn, "'%s' = %g is outside [%g, %g]", key, v, lo, hi);
    *out = v;
    return 0;
}

static int get_id(json_t *obj, uint32_t *out, char *why, size_t wn)
{
    json_t *x = json_object_get(obj, "id");
    if (!json_is_integer(x))
        return fail(why, wn, "'id' is missing or not an integer");
    json_int_t v = json_integer_value(x);
    if (v < 1 || v > (json_int_t)VIS_MAX_OBJECT_ID)
        return fail(why, wn, "'id' = %lld is outside [1, %u]", (long long)v, VIS_MAX_OBJECT_ID);
    *out = (uint32_t)v;
    return 0;
}

#define COORD 1e9
#define SPEED VIS_QUERY_MAX_SPEED

static int parse_viewer(json_t *o, vis_query_viewer *v, char *why, size_t wn)
{
    memset(v, 0, sizeof *v);
    if (!json_is_object(o))
        return fail(why, wn, "not an object");
    if (get_id(o, &v->id, why, wn) || get_vec3(o, "eye", 1, -COORD, COORD, v->eye, why, wn) ||
        get_vec3(o, "dir", 0, -COORD, COORD, v->dir, why, wn) ||
        get_number(o, "fov", 0, 90.0, VIS_QUERY_MIN_FOV, VIS_QUERY_MAX_FOV, &v->fov_deg, why, wn) ||
        get_vec3(o, "vel", 0, -SPEED, SPEED, v->velocity, why, wn) ||
        get_number(o, "latency_ms", 0, 0.0, 0.0, VIS_QUERY_MAX_LATENCY_MS, &v->latency_ms, why, wn))
        return -1;
    return 0;
}

static int parse_entity(json_t *o, vis_query_entity *e, char *why, size_t wn)
{
    memset(e, 0, sizeof *e);
    if (!json_is_object(o))
        return fail(why, wn, "not an object");
    if (get_id(o, &e->id, why, wn) || get_vec3(o, "min", 1, -COORD, COORD, e->box_min, why, wn) ||
        get_vec3(o, "max", 1, -COORD, COORD, e->box_max, why, wn) ||
        get_vec3(o, "vel", 0, -SPEED, SPEED, e->velocity, why, wn))
        return -1;
    for (int i = 0; i < 3; ++i)
        if (!(e->box_min[i] < e->box_max[i]) || e->box_max[i] - e->box_min[i] > 1e5)
            return fail(why, wn, "'min'[%d] = %g, 'max'[%d] = %g: a box needs min < max, at most 1e5 apart", i,
                        e->box_min[i], i, e->box_max[i]);
    return 0;
}

static int parse_edit(qr_reader *r, json_t *a, qr_edit *e, char *why, size_t wn)
{
    if (!json_is_array(a) || json_array_size(a) != 4)
        return fail(why, wn, "an edit is [x, y, z, value]");
    json_int_t v[4];
    for (size_t i = 0; i < 4; ++i) {
        json_t *x = json_array_get(a, i);
        if (!json_is_integer(x))
            return fail(why, wn, "edit field %zu is not an integer", i);
        v[i] = json_integer_value(x);
    }
    for (int i = 0; i < 3; ++i)
        if (v[i] < r->wmin[i] || v[i] >= r->wmax[i])
            return fail(why, wn, "edit coordinate %d = %lld is outside the world [%lld, %lld)", i, (long long)v[i],
                        (long long)r->wmin[i], (long long)r->wmax[i]);
    if (v[3] < 0 || v[3] > 255)
        return fail(why, wn, "edit value %lld is outside [0, 255]", (long long)v[3]);
    e->x = v[0];
    e->y = v[1];
    e->z = v[2];
    e->value = (uint32_t)v[3];
    return 0;
}

static int parse_header(qr_reader *r, json_t *root, char *why, size_t wn)
{
    json_t *ver = json_object_get(root, "version");
    if (!json_is_integer(ver) || json_integer_value(ver) != 1)
        return fail(why, wn, "the header's 'version' must be 1");
    json_t *scene = json_object_get(root, "scene");
    if (scene) {
        if (!json_is_string(scene) || json_string_length(scene) >= sizeof r->header.scene)
            return fail(why, wn, "'scene' must be a string shorter than %zu bytes", sizeof r->header.scene);
        memcpy(r->header.scene, json_string_value(scene), json_string_length(scene) + 1);
    }
    /* 0 (or absent): the command's --tick-ms; otherwise the same range as --tick-ms. */
    if (get_number(root, "tick_ms", 0, 0.0, 0.0, 1e4, &r->header.tick_ms, why, wn))
        return -1;
    if (r->header.tick_ms != 0.0 && r->header.tick_ms < 0.1)
        return fail(why, wn, "'tick_ms' = %g is outside [0.1, 10000] (0: --tick-ms)", r->header.tick_ms);
    return 0;
}

static int parse_tick(qr_reader *r, json_t *root, qr_tick *t, char *why, size_t wn)
{
    json_t *tick = json_object_get(root, "tick");
    if (!json_is_integer(tick) || json_integer_value(tick) < 0)
        return fail(why, wn, "'tick' is missing or not a non-negative integer");
    t->tick = (uint64_t)json_integer_value(tick);
    json_t *vw = json_object_get(root, "viewers"), *en = json_object_get(root, "entities"),
           *ed = json_object_get(root, "edits");
    if (!json_is_array(vw) || (en && !json_is_array(en)) || (ed && !json_is_array(ed)))
        return fail(why, wn, "'viewers' must be an array ('entities' and 'edits' arrays when present)");
    size_t nv = json_array_size(vw), ne = en ? json_array_size(en) : 0, nd = ed ? json_array_size(ed) : 0;
    if (nv > r->max_viewers || ne > r->max_entities || nd > QR_MAX_EDITS)
        return fail(why, wn, "%zu viewers, %zu entities, %zu edits: at most %u, %u and %u (--max-viewers, "
                             "--max-entities)", nv, ne, nd, r->max_viewers, r->max_entities, QR_MAX_EDITS);
    char sub[256];
    for (size_t i = 0; i < nv; ++i)
        if (parse_viewer(json_array_get(vw, i), &r->viewers[i], sub, sizeof sub))
            return fail(why, wn, "viewers[%zu]: %s", i, sub);
    for (size_t i = 0; i < ne; ++i)
        if (parse_entity(json_array_get(en, i), &r->entities[i], sub, sizeof sub))
            return fail(why, wn, "entities[%zu]: %s", i, sub);
    for (size_t i = 0; i < nd; ++i)
        if (parse_edit(r, json_array_get(ed, i), &r->edits[i], sub, sizeof sub))
            return fail(why, wn, "edits[%zu]: %s", i, sub);
    t->viewers = r->viewers;
    t->viewer_count = (uint32_t)nv;
    t->entities = r->entities;
    t->entity_count = (uint32_t)ne;
    t->edits = r->edits;
    t->edit_count = (uint32_t)nd;
    return 0;
}

int qr_next(qr_reader *r, qr_tick *out, char *err, size_t err_size)
{
    for (;;) {
        size_t len = 0;
        int nl = 0;
        int rc = read_line(r, &len, &nl);
        if (rc == 0)
            return 0;
        if (rc == -2)
            return fail(err, err_size, "line %llu: read error: %s", (unsigned long long)r->line_no + 1,
                        strerror(errno));
        if (rc < 0)
            return fail(err, err_size, "line %llu: longer than %u bytes", (unsigned long long)r->line_no + 1,
                        QR_MAX_LINE_BYTES);
        size_t s = 0;
        while (s < len && (r->line[s] == ' ' || r->line[s] == '\t' || r->line[s] == '\r'))
            ++s;
        if (s == len)
            continue; /* blank line */
        json_error_t je;
        json_t *root = json_loadb(r->line + s, len - s, JSON_REJECT_DUPLICATES, &je);
        if (!root)
            return fail(err, err_size, "line %llu: %s%s", (unsigned long long)r->line_no, je.text,
                        nl ? "" : " (the last line is cut short)");
        char why[512];
        int bad;
        if (!json_is_object(root)) {
            bad = fail(why, sizeof why, "a line must be a JSON object");
        } else if (json_object_get(root, "replay")) {
            bad = r->header_checked ? fail(why, sizeof why, "a header is only allowed on the first line")
                                    : parse_header(r, root, why, sizeof why);
            r->header_checked = 1;
            if (!bad) {
                json_decref(root);
                continue;
            }
        } else {
            bad = parse_tick(r, root, out, why, sizeof why);
        }
        r->header_checked = 1;
        json_decref(root);
        if (bad)
            return fail(err, err_size, "line %llu: %s", (unsigned long long)r->line_no, why);
        return 1;
    }
}
#else
typedef int vis_query_replay_needs_jansson; /* ISO C forbids an empty translation unit */
#endif
