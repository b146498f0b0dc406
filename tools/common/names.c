/* names.c — command-line names of the library's enumerations, one table each. */
#include "names.h"

#include <string.h>

static const vc_name traversal_names[] = {
    {"stack", VIS_TRAVERSAL_STACK},
    {"bruteforce", VIS_TRAVERSAL_BRUTEFORCE},
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
