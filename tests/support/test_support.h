/* test_support.h — small helpers shared by the cmocka tests. */
#ifndef VIS_TEST_SUPPORT_H
#define VIS_TEST_SUPPORT_H

#include <stddef.h>
#include <stdint.h>

/* ../shared/data beside the checkout (or $VIS_SHARED_DATA), or NULL when absent. */
const char *vt_shared_data_dir(void);

/* Path of a file under the shared data dir ("vox/x.vox"), or NULL (and a printed
 * "SKIP: ..." line saying why) when the data is absent. Returns a static buffer. */
const char *vt_shared_file(const char *relative);

/* 1 when tests should run a reduced number of iterations ($VIS_TEST_SCALE=small, as the
 * sanitizer build sets). Every test still runs every case, only fewer random repetitions. */
int vt_small(void);

/* VT_ASAN: defined in builds with AddressSanitizer (GCC's macro, clang's feature test). */
#if defined(__SANITIZE_ADDRESS__)
#define VT_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define VT_ASAN 1
#endif
#endif

/* Reads a whole file; caller frees. NULL on failure. */
void *vt_read_file(const char *path, size_t *out_size);

/* An allocator over aligned_alloc and free, for the tests that keep the CPU backend's
 * records (labels, subtree fills) themselves. */
struct vis_allocator;
const struct vis_allocator *vt_heap_allocator(void);

/* The CPU backend's voxel labels (backends/cpu/labels.h) of a view, built whole on the
 * calling thread from malloc'd memory, for the tests that call the walks directly; free with
 * vis_labels_free. Returns vis_labels_sync's status. */
struct vis_labels;
struct vis_scene_view;
int vt_labels_build(struct vis_labels *out, const struct vis_scene_view *view);

/* A deterministic 64-bit generator (splitmix64) for random tests. */
uint64_t vt_rand(uint64_t *state);
double vt_rand_unit(uint64_t *state); /* [0, 1) */

#endif
