/* drawlist_check.c — see drawlist_check.h. */
#include "drawlist_check.h"

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

size_t check_trace_drawlist(vis_context *ref_ctx, vis_scene *ref_scene, vis_context *ctx, vis_scene *scene,
                          const vis_camera *cams, uint32_t count, const vis_trace_desc *td, const char *what)
{
    size_t px = (size_t)td->width * td->height;
    size_t bound = vis_drawlist_bound(ref_scene);
    size_t cap = bound + 1;
    uint32_t *ref_ids = malloc(px * 4), *ids = malloc(px * 4);
    float *ref_depth = malloc(px * 4), *depth = malloc(px * 4);
    vis_draw_entry *ref = malloc(cap * count * sizeof *ref), *got = malloc(cap * count * sizeof *got);
    size_t *ref_n = calloc(count, sizeof *ref_n), *got_n = calloc(count, sizeof *got_n);
    size_t ref_total = 0;
    for (uint32_t v = 0; v < count; ++v) {
        if (vis_trace(ref_ctx, ref_scene, &cams[v], td, ref_ids, px, ref_depth, px) != VIS_OK)
            fail_msg("%s: reference trace: %s", what, vis_context_last_error(ref_ctx));
        if (vis_drawlist_build(ref_ctx, ref_scene, ref_ids, td->width, td->height, td->ids, ref + ref_total,
                               cap * count - ref_total, &ref_n[v]) != VIS_OK)
            fail_msg("%s: reference list: %s", what, vis_context_last_error(ref_ctx));
        /* One view, lists only. */
        size_t n = 0;
        if (vis_trace_drawlist(ctx, scene, &cams[v], td, got, cap, &n, NULL, 0, NULL, 0) != VIS_OK)
            fail_msg("%s: view %u: %s", what, v, vis_context_last_error(ctx));
        if (n != ref_n[v] || memcmp(got, ref + ref_total, n * sizeof *got) != 0)
            fail_msg("%s: view %u (ids %d, traversal %d): %zu entries, reference %zu (first: %u/%u vs %u/%u)", what, v,
                     (int)td->ids, (int)td->traversal, n, ref_n[v], n ? got[0].id : 0, n ? got[0].pixels : 0,
                     ref_n[v] ? ref[ref_total].id : 0, ref_n[v] ? ref[ref_total].pixels : 0);
        /* With the IDs and depths read back: the same list, vis_trace's buffers. */
        memset(ids, 0xAB, px * 4);
        memset(depth, 0xAB, px * 4);
        n = 0;
        if (vis_trace_drawlist(ctx, scene, &cams[v], td, got, cap, &n, ids, px, depth, px) != VIS_OK)
            fail_msg("%s: view %u with IDs: %s", what, v, vis_context_last_error(ctx));
        assert_int_equal(n, ref_n[v]);
        assert_memory_equal(got, ref + ref_total, n * sizeof *got);
        assert_memory_equal(ids, ref_ids, px * 4);
        assert_memory_equal(depth, ref_depth, px * 4);
        vis_timing t;
        assert_int_equal(vis_context_last_timing(ctx, &t), VIS_OK);
        assert_int_equal(t.views, 1);
        assert_int_equal(t.rays, px);
        /* One entry short: refused with the count, entries untouched. */
        if (ref_n[v] > 0) {
            memset(got, 0x5A, cap * sizeof *got);
            n = 0;
            assert_int_equal(vis_trace_drawlist(ctx, scene, &cams[v], td, got, ref_n[v] - 1, &n, NULL, 0, NULL, 0),
                             VIS_ERROR_CAPACITY);
            assert_int_equal(n, ref_n[v]);
            for (size_t i = 0; i < cap * sizeof *got; ++i)
                assert_int_equal(((unsigned char *)got)[i], 0x5A);
        }
        ref_total += ref_n[v];
    }
    /* The batch: the same lists, one after the other. */
    size_t total = 0;
    if (vis_trace_batch_drawlist(ctx, scene, cams, count, td, got, cap * count, got_n, count, &total) != VIS_OK)
        fail_msg("%s: batch: %s", what, vis_context_last_error(ctx));
    assert_int_equal(total, ref_total);
    assert_memory_equal(got_n, ref_n, count * sizeof *got_n);
    assert_memory_equal(got, ref, ref_total * sizeof *got);
    if (ref_total > 0) {
        assert_int_equal(vis_trace_batch_drawlist(ctx, scene, cams, count, td, got, ref_total - 1, got_n, count, &total),
                         VIS_ERROR_CAPACITY);
        assert_true(total >= ref_total);
    }
    assert_int_equal(vis_trace_batch_drawlist(ctx, scene, cams, count, td, got, cap * count, got_n, count - 1, &total),
                     VIS_ERROR_CAPACITY);
    size_t longest = 0;
    for (uint32_t v = 0; v < count; ++v)
        longest = ref_n[v] > longest ? ref_n[v] : longest;
    free(ref_ids), free(ids), free(ref_depth), free(depth), free(ref), free(got), free(ref_n), free(got_n);
    return longest;
}
