/* json.h — a small streaming JSON writer for the tools' --json output (one object, one line). */
#ifndef VIS_CLI_JSON_H
#define VIS_CLI_JSON_H

#include <stdint.h>
#include <stdio.h>

#define JSON_MAX_DEPTH 16

typedef struct json_writer {
    FILE *f;
    int depth;
    int count[JSON_MAX_DEPTH]; /* values written at each level, for the commas */
} json_writer;

void json_init(json_writer *w, FILE *f);

/* s as a JSON string literal, quotes included (for output written without a writer). */
void json_quoted(FILE *f, const char *s);

/* `key` is the member name inside an object, NULL inside an array or at the top level. */
void json_object_begin(json_writer *w, const char *key);
void json_object_end(json_writer *w); /* at depth 0 also ends the line */
void json_array_begin(json_writer *w, const char *key);
void json_array_end(json_writer *w);

void json_string(json_writer *w, const char *key, const char *value); /* NULL -> null */
void json_number(json_writer *w, const char *key, double value);      /* inf/NaN -> null */
void json_uint(json_writer *w, const char *key, uint64_t value);
void json_int(json_writer *w, const char *key, int64_t value);
void json_bool(json_writer *w, const char *key, int value);
void json_null(json_writer *w, const char *key);
/* [v0, v1, v2] of doubles. */
void json_vec3(json_writer *w, const char *key, const double v[3]);

#endif
