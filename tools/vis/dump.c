/* dump.c — writes the ID, depth and draw-list dumps (through out_file.h: a failed write never
 * destroys the file that was there). */
#include "dump.h"

#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "list_file.h"
#include "out_file.h"

static int finish(const char *cmd, vc_out_file *f)
{
    char err[1024];
    if (vc_out_close(f, 1, err, sizeof err) != 0)
        return cli_fail(cmd, "%s", err);
    return CLI_EXIT_OK;
}

/* Writes 32-bit words little-endian whatever the host's byte order, through a small buffer. */
static int write_words_le(const char *cmd, const char *path, const void *words, size_t count)
{
    char err[1024];
    vc_out_file f;
    if (vc_out_open(&f, path, err, sizeof err) != 0)
        return cli_fail(cmd, "%s", err);
    const unsigned char *src = words;
    unsigned char buf[4096];
    for (size_t i = 0; i < count && !f.error; i += sizeof buf / 4) {
        size_t n = count - i < sizeof buf / 4 ? count - i : sizeof buf / 4;
        for (size_t k = 0; k < n; ++k) {
            uint32_t w;
            memcpy(&w, src + 4 * (i + k), 4);
            buf[4 * k + 0] = (unsigned char)w;
            buf[4 * k + 1] = (unsigned char)(w >> 8);
            buf[4 * k + 2] = (unsigned char)(w >> 16);
            buf[4 * k + 3] = (unsigned char)(w >> 24);
        }
        vc_out_write(&f, buf, 4 * n);
    }
    return finish(cmd, &f);
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

int cli_dump_effect_list(const char *cmd, const char *path, const vis_effect_entry *entries, size_t count)
{
    char err[1024];
    if (vc_effect_list_write(path, entries, count, err, sizeof err) != 0)
        return cli_fail(cmd, "%s", err);
    return CLI_EXIT_OK;
}

int cli_dump_list(const char *cmd, const char *path, const vis_draw_entry *entries, size_t count)
{
    char err[1024];
    if (vc_list_write(path, entries, count, err, sizeof err) != 0)
        return cli_fail(cmd, "%s", err);
    return CLI_EXIT_OK;
}
