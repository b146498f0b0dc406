/* dump.c — writes the ID, depth and draw-list dumps. */
#include "dump.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "cli.h"

/* Writes 32-bit words little-endian whatever the host's byte order, through a small buffer. */
static int write_words_le(const char *cmd, const char *path, const void *words, size_t count)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return cli_fail(cmd, "cannot open %s for writing: %s", path, strerror(errno));
    const unsigned char *src = words;
    unsigned char buf[4096];
    int bad = 0;
    for (size_t i = 0; i < count && !bad; i += sizeof buf / 4) {
        size_t n = count - i < sizeof buf / 4 ? count - i : sizeof buf / 4;
        for (size_t k = 0; k < n; ++k) {
            uint32_t w;
            memcpy(&w, src + 4 * (i + k), 4);
            buf[4 * k + 0] = (unsigned char)w;
            buf[4 * k + 1] = (unsigned char)(w >> 8);
            buf[4 * k + 2] = (unsigned char)(w >> 16);
            buf[4 * k + 3] = (unsigned char)(w >> 24);
        }
        bad = fwrite(buf, 4, n, f) != n;
    }
    if (fclose(f) != 0)
        bad = 1;
    if (bad)
        return cli_fail(cmd, "writing %s failed: %s", path, strerror(errno));
    return CLI_EXIT_OK;
}

int cli_dump_ids(const char *cmd, const char *path, const uint32_t *ids, size_t count)
{
    return write_words_le(cmd, path, ids, count);
}

int cli_dump_depth(const char *cmd, const char *path, const float *depth, size_t count)
{
    _Static_assert(sizeof(float) == 4, "float32 dumps need a 32-bit float");
    return write_words_le(cmd, path, depth, count);
}

int cli_dump_list(const char *cmd, const char *path, const vis_draw_entry *entries, size_t count)
{
    FILE *f = fopen(path, "w");
    if (!f)
        return cli_fail(cmd, "cannot open %s for writing: %s", path, strerror(errno));
    int bad = 0;
    for (size_t i = 0; i < count && !bad; ++i)
        bad = fprintf(f, "%u %u\n", entries[i].id, entries[i].pixels) < 0;
    if (fclose(f) != 0)
        bad = 1;
    if (bad)
        return cli_fail(cmd, "writing %s failed: %s", path, strerror(errno));
    return CLI_EXIT_OK;
}
