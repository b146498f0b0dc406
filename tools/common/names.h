/* names.h — the one table per enumeration that the tools accept on their command lines and
 * print in their output (traversal methods, backends, ID modes). A new traversal method is
 * one row in names.c. */
#ifndef VIS_TOOLS_NAMES_H
#define VIS_TOOLS_NAMES_H

#include <stddef.h>

#include "vis/vis.h"

typedef struct vc_name {
    const char *name;
    int value;
} vc_name;

typedef struct vc_name_table {
    const vc_name *entries;
    size_t count;
    const char *what; /* "traversal", ... for messages */
} vc_name_table;

extern const vc_name_table vc_traversals; /* vis_traversal, and N: see below */

/* A vc_traversals value is the method, with the short-stack depth N of "shortstack:N" and
 * "ropes-shortstack:N" above it (N = 0: the library's default). */
#define VC_TRAVERSAL(method, n) ((int)(method) | ((int)(n) << 8))
static inline vis_traversal vc_traversal_method(int value) { return (vis_traversal)(value & 0xFF); }
static inline uint32_t vc_traversal_short_stack(int value) { return (uint32_t)value >> 8; }
extern const vc_name_table vc_backends;   /* vis_backend_kind */
extern const vc_name_table vc_id_modes;   /* vis_id_mode      */

/* 0 and *out = value when `name` is in the table (exact, case-sensitive), -1 otherwise. */
int vc_name_lookup(const vc_name_table *table, const char *name, int *out);

/* The name of a value, or "?" when it has none. */
const char *vc_name_of(const vc_name_table *table, int value);

/* The name of the method a traversal value runs on a backend ("auto" resolved: "packet" on
 * the CPU, "stack" elsewhere; N of the short-stack methods included). */
const char *vc_traversal_run_name(int value, vis_backend_kind kind);

/* Every name, joined by `sep` ("stack|bruteforce"), into buf (truncated, NUL-terminated). */
void vc_name_list(const vc_name_table *table, const char *sep, char *buf, size_t capacity);

#endif
