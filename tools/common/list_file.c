/* list_file.c — draw lists as text (list_file.h). */
#include "list_file.h"

#include "out_file.h"

int vc_list_write(const char *path, const vis_draw_entry *entries, size_t count, char *err, size_t err_size)
{
    vc_out_file f;
    if (vc_out_open(&f, path, err, err_size) != 0)
        return -1;
    for (size_t i = 0; i < count && !f.error; ++i)
        vc_out_printf(&f, "%u %u\n", entries[i].id, entries[i].pixels);
    return vc_out_close(&f, 1, err, err_size);
}

int vc_effect_list_write(const char *path, const vis_effect_entry *entries, size_t count, char *err,
                         size_t err_size)
{
    _Static_assert(VIS_REASON_COUNT == 4, "the file has one column per reason");
    vc_out_file f;
    if (vc_out_open(&f, path, err, err_size) != 0)
        return -1;
    for (size_t i = 0; i < count && !f.error; ++i) {
        const vis_effect_entry *e = &entries[i];
        vc_out_printf(&f, "%u %u %u %u %u\n", e->id, e->pixels[0], e->pixels[1], e->pixels[2], e->pixels[3]);
    }
    return vc_out_close(&f, 1, err, err_size);
}
