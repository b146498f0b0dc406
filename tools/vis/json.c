/* json.c — streaming JSON writer (RFC 8259 strings; non-finite numbers become null). */
#include "json.h"

#include <inttypes.h>
#include <math.h>

void json_init(json_writer *w, FILE *f)
{
    w->f = f;
    w->depth = 0;
    w->count[0] = 0;
}

void json_quoted(FILE *f, const char *s)
{
    fputc('"', f);
    for (const unsigned char *c = (const unsigned char *)s; *c; ++c) {
        switch (*c) {
        case '"': fputs("\\\"", f); break;
        case '\\': fputs("\\\\", f); break;
        case '\n': fputs("\\n", f); break;
        case '\r': fputs("\\r", f); break;
        case '\t': fputs("\\t", f); break;
        default:
            if (*c < 0x20)
                fprintf(f, "\\u%04x", *c);
            else
                fputc(*c, f);
        }
    }
    fputc('"', f);
}

/* The comma and the key before a value. */
static void prefix(json_writer *w, const char *key)
{
    if (w->count[w->depth]++ > 0)
        fputs(", ", w->f);
    if (key) {
        json_quoted(w->f, key);
        fputs(": ", w->f);
    }
}

static void begin_container(json_writer *w, const char *key, char c)
{
    prefix(w, key);
    fputc(c, w->f);
    if (w->depth + 1 < JSON_MAX_DEPTH)
        ++w->depth;
    w->count[w->depth] = 0;
}

static void end_container(json_writer *w, char c)
{
    fputc(c, w->f);
    if (w->depth > 0)
        --w->depth;
    if (w->depth == 0 && c == '}')
        fputc('\n', w->f);
}

void json_object_begin(json_writer *w, const char *key) { begin_container(w, key, '{'); }
void json_object_end(json_writer *w) { end_container(w, '}'); }
void json_array_begin(json_writer *w, const char *key) { begin_container(w, key, '['); }
void json_array_end(json_writer *w) { end_container(w, ']'); }

void json_string(json_writer *w, const char *key, const char *value)
{
    prefix(w, key);
    if (value)
        json_quoted(w->f, value);
    else
        fputs("null", w->f);
}

void json_number(json_writer *w, const char *key, double value)
{
    prefix(w, key);
    if (isfinite(value))
        fprintf(w->f, "%.6g", value);
    else
        fputs("null", w->f);
}

void json_uint(json_writer *w, const char *key, uint64_t value)
{
    prefix(w, key);
    fprintf(w->f, "%" PRIu64, value);
}

void json_int(json_writer *w, const char *key, int64_t value)
{
    prefix(w, key);
    fprintf(w->f, "%" PRId64, value);
}

void json_bool(json_writer *w, const char *key, int value)
{
    prefix(w, key);
    fputs(value ? "true" : "false", w->f);
}

void json_null(json_writer *w, const char *key)
{
    prefix(w, key);
    fputs("null", w->f);
}

void json_vec3(json_writer *w, const char *key, const double v[3])
{
    json_array_begin(w, key);
    for (int i = 0; i < 3; ++i)
        json_number(w, NULL, v[i]);
    json_array_end(w);
}
