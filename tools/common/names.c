/* names.c — command-line names of the library's enumerations, one table each. */
#include "names.h"

#include <string.h>

/* Values of the short-stack methods carry N: VC_TRAVERSAL(method, N), see names.h. */
static const vc_name traversal_names[] = {
    {"auto", VIS_TRAVERSAL_AUTO},
    {"stack", VIS_TRAVERSAL_STACK},
    {"bruteforce", VIS_TRAVERSAL_BRUTEFORCE},
    {"restart", VIS_TRAVERSAL_RESTART},
    {"pushdown", VIS_TRAVERSAL_PUSHDOWN},
    {"ropes", VIS_TRAVERSAL_ROPES},
    {"shortstack", VIS_TRAVERSAL_SHORTSTACK}, /* the library default N */
    {"ropes-shortstack", VIS_TRAVERSAL_ROPES_SHORTSTACK},
    {"packet", VIS_TRAVERSAL_PACKET},
    {"cached-stack", VIS_TRAVERSAL_CACHED_STACK}, /* the library default ring */
    {"dda", VIS_TRAVERSAL_DDA},
    {"shortstack:1", VC_TRAVERSAL(VIS_TRAVERSAL_SHORTSTACK, 1)},
    {"shortstack:2", VC_TRAVERSAL(VIS_TRAVERSAL_SHORTSTACK, 2)},
    {"shortstack:3", VC_TRAVERSAL(VIS_TRAVERSAL_SHORTSTACK, 3)},
    {"shortstack:4", VC_TRAVERSAL(VIS_TRAVERSAL_SHORTSTACK, 4)},
    {"shortstack:5", VC_TRAVERSAL(VIS_TRAVERSAL_SHORTSTACK, 5)},
    {"shortstack:6", VC_TRAVERSAL(VIS_TRAVERSAL_SHORTSTACK, 6)},
    {"shortstack:7", VC_TRAVERSAL(VIS_TRAVERSAL_SHORTSTACK, 7)},
    {"shortstack:8", VC_TRAVERSAL(VIS_TRAVERSAL_SHORTSTACK, 8)},
    {"shortstack:9", VC_TRAVERSAL(VIS_TRAVERSAL_SHORTSTACK, 9)},
    {"shortstack:10", VC_TRAVERSAL(VIS_TRAVERSAL_SHORTSTACK, 10)},
    {"shortstack:11", VC_TRAVERSAL(VIS_TRAVERSAL_SHORTSTACK, 11)},
    {"shortstack:12", VC_TRAVERSAL(VIS_TRAVERSAL_SHORTSTACK, 12)},
    {"shortstack:13", VC_TRAVERSAL(VIS_TRAVERSAL_SHORTSTACK, 13)},
    {"shortstack:14", VC_TRAVERSAL(VIS_TRAVERSAL_SHORTSTACK, 14)},
    {"shortstack:15", VC_TRAVERSAL(VIS_TRAVERSAL_SHORTSTACK, 15)},
    {"shortstack:16", VC_TRAVERSAL(VIS_TRAVERSAL_SHORTSTACK, 16)},
    {"ropes-shortstack:1", VC_TRAVERSAL(VIS_TRAVERSAL_ROPES_SHORTSTACK, 1)},
    {"ropes-shortstack:2", VC_TRAVERSAL(VIS_TRAVERSAL_ROPES_SHORTSTACK, 2)},
    {"ropes-shortstack:3", VC_TRAVERSAL(VIS_TRAVERSAL_ROPES_SHORTSTACK, 3)},
    {"ropes-shortstack:4", VC_TRAVERSAL(VIS_TRAVERSAL_ROPES_SHORTSTACK, 4)},
    {"ropes-shortstack:5", VC_TRAVERSAL(VIS_TRAVERSAL_ROPES_SHORTSTACK, 5)},
    {"ropes-shortstack:6", VC_TRAVERSAL(VIS_TRAVERSAL_ROPES_SHORTSTACK, 6)},
    {"ropes-shortstack:7", VC_TRAVERSAL(VIS_TRAVERSAL_ROPES_SHORTSTACK, 7)},
    {"ropes-shortstack:8", VC_TRAVERSAL(VIS_TRAVERSAL_ROPES_SHORTSTACK, 8)},
    {"ropes-shortstack:9", VC_TRAVERSAL(VIS_TRAVERSAL_ROPES_SHORTSTACK, 9)},
    {"ropes-shortstack:10", VC_TRAVERSAL(VIS_TRAVERSAL_ROPES_SHORTSTACK, 10)},
    {"ropes-shortstack:11", VC_TRAVERSAL(VIS_TRAVERSAL_ROPES_SHORTSTACK, 11)},
    {"ropes-shortstack:12", VC_TRAVERSAL(VIS_TRAVERSAL_ROPES_SHORTSTACK, 12)},
    {"ropes-shortstack:13", VC_TRAVERSAL(VIS_TRAVERSAL_ROPES_SHORTSTACK, 13)},
    {"ropes-shortstack:14", VC_TRAVERSAL(VIS_TRAVERSAL_ROPES_SHORTSTACK, 14)},
    {"ropes-shortstack:15", VC_TRAVERSAL(VIS_TRAVERSAL_ROPES_SHORTSTACK, 15)},
    {"ropes-shortstack:16", VC_TRAVERSAL(VIS_TRAVERSAL_ROPES_SHORTSTACK, 16)},
    {"cached-stack:1", VC_TRAVERSAL(VIS_TRAVERSAL_CACHED_STACK, 1)},
    {"cached-stack:2", VC_TRAVERSAL(VIS_TRAVERSAL_CACHED_STACK, 2)},
    {"cached-stack:3", VC_TRAVERSAL(VIS_TRAVERSAL_CACHED_STACK, 3)},
    {"cached-stack:4", VC_TRAVERSAL(VIS_TRAVERSAL_CACHED_STACK, 4)},
    {"cached-stack:5", VC_TRAVERSAL(VIS_TRAVERSAL_CACHED_STACK, 5)},
    {"cached-stack:6", VC_TRAVERSAL(VIS_TRAVERSAL_CACHED_STACK, 6)},
    {"cached-stack:7", VC_TRAVERSAL(VIS_TRAVERSAL_CACHED_STACK, 7)},
    {"cached-stack:8", VC_TRAVERSAL(VIS_TRAVERSAL_CACHED_STACK, 8)},
    {"cached-stack:9", VC_TRAVERSAL(VIS_TRAVERSAL_CACHED_STACK, 9)},
    {"cached-stack:10", VC_TRAVERSAL(VIS_TRAVERSAL_CACHED_STACK, 10)},
    {"cached-stack:11", VC_TRAVERSAL(VIS_TRAVERSAL_CACHED_STACK, 11)},
    {"cached-stack:12", VC_TRAVERSAL(VIS_TRAVERSAL_CACHED_STACK, 12)},
    {"cached-stack:13", VC_TRAVERSAL(VIS_TRAVERSAL_CACHED_STACK, 13)},
    {"cached-stack:14", VC_TRAVERSAL(VIS_TRAVERSAL_CACHED_STACK, 14)},
    {"cached-stack:15", VC_TRAVERSAL(VIS_TRAVERSAL_CACHED_STACK, 15)},
    {"cached-stack:16", VC_TRAVERSAL(VIS_TRAVERSAL_CACHED_STACK, 16)},
};

static const vc_name backend_names[] = {
    {"auto", VIS_BACKEND_AUTO},
    {"cpu", VIS_BACKEND_CPU},
    {"opencl", VIS_BACKEND_OPENCL},
};

static const vc_name id_mode_names[] = {
    {"object", VIS_IDS_OBJECT},
    {"leaf", VIS_IDS_LEAF},
};

#define TABLE(arr, what) {arr, sizeof arr / sizeof arr[0], what}
const vc_name_table vc_traversals = TABLE(traversal_names, "traversal");
const vc_name_table vc_backends = TABLE(backend_names, "backend");
const vc_name_table vc_id_modes = TABLE(id_mode_names, "ID mode");

int vc_name_lookup(const vc_name_table *table, const char *name, int *out)
{
    for (size_t i = 0; i < table->count; ++i) {
        if (strcmp(table->entries[i].name, name) == 0) {
            *out = table->entries[i].value;
            return 0;
        }
    }
    return -1;
}

const char *vc_name_of(const vc_name_table *table, int value)
{
    for (size_t i = 0; i < table->count; ++i)
        if (table->entries[i].value == value)
            return table->entries[i].name;
    return "?";
}

void vc_name_list(const vc_name_table *table, const char *sep, char *buf, size_t capacity)
{
    size_t used = 0;
    if (capacity == 0)
        return;
    buf[0] = '\0';
    for (size_t i = 0; i < table->count; ++i) {
        const char *parts[2] = {i ? sep : "", table->entries[i].name};
        for (int p = 0; p < 2; ++p) {
            for (const char *c = parts[p]; *c && used + 1 < capacity; ++c)
                buf[used++] = *c;
        }
    }
    buf[used] = '\0';
}

const char *vc_traversal_run_name(int value, vis_backend_kind kind)
{
    if (vc_traversal_method(value) == VIS_TRAVERSAL_AUTO)
        return kind == VIS_BACKEND_CPU ? "packet" : "stack";
    return vc_name_of(&vc_traversals, value);
}
