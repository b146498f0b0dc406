#include "test_support.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

const char *vt_shared_data_dir(void)
{
    const char *env = getenv("VIS_SHARED_DATA");
    const char *dir = env && *env ? env : VIS_SHARED_DATA_DIR;
    struct stat st;
    if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode))
        return NULL;
    return dir;
}

const char *vt_shared_file(const char *relative)
{
    static char path[4096];
    const char *dir = vt_shared_data_dir();
    if (!dir) {
        printf("SKIP: shared data directory not found (set VIS_SHARED_DATA); %s not tested\n", relative);
        return NULL;
    }
    snprintf(path, sizeof path, "%s/%s", dir, relative);
    struct stat st;
    if (stat(path, &st) != 0) {
        printf("SKIP: %s is absent from the shared data\n", path);
        return NULL;
    }
    return path;
}

int vt_small(void)
{
    const char *s = getenv("VIS_TEST_SCALE");
    return s && strcmp(s, "small") == 0;
}

void *vt_read_file(const char *path, size_t *out_size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    if (fseek(f, 0, SEEK_END) != 0) {
        fclose(f);
        return NULL;
    }
    long n = ftell(f);
    rewind(f);
    void *buf = malloc(n > 0 ? (size_t)n : 1);
    if (buf && n > 0 && fread(buf, 1, (size_t)n, f) != (size_t)n) {
        free(buf);
        buf = NULL;
    }
    fclose(f);
    if (buf && out_size)
        *out_size = (size_t)(n > 0 ? n : 0);
    return buf;
}

uint64_t vt_rand(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

double vt_rand_unit(uint64_t *state)
{
    return (double)(vt_rand(state) >> 11) * (1.0 / 9007199254740992.0);
}

/* ---- the CPU backend's labels, for the walks called directly ------------------------------ */

#include "cpu/labels.h"

static void *heap_alloc(size_t size, size_t align, void *user)
{
    (void)user;
    size_t rounded = (size + align - 1) / align * align;
    return aligned_alloc(align, rounded ? rounded : align);
}

static void heap_free(void *p, void *user)
{
    (void)user;
    free(p);
}

static const vis_allocator heap = {heap_alloc, heap_free, NULL};

const vis_allocator *vt_heap_allocator(void) { return &heap; }

int vt_labels_build(struct vis_labels *out, const struct vis_scene_view *view)
{
    memset(out, 0, sizeof *out);
    out->alloc = &heap;
    vis_scene_changes full;
    memset(&full, 0, sizeof full);
    full.full = 1;
    return (int)vis_labels_sync(out, view, &full, UINT64_MAX, NULL, NULL); /* on this thread */
}
