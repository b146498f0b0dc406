/* scene_stats.c — vis_scene_get_stats: how a scene's memory is used inside (pool slots,
 * relocations, ropes), for benchmarks and debugging. Nothing here is on a trace's path.
 *
 * Rope memory per short-stack level follows Chang & Ihm 2010, Table 4: a ropes-shortstack
 * pass with N walks the rope nodes N levels above the leaves. */
#include <string.h>

#include "scene.h"

/* Bytes of the rope nodes a pass with short stack N walks (N = 0: plain ropes): on each
 * root-to-leaf path the highest node of height <= N, i.e. the nodes of height <= N whose
 * parent is higher than N. */
static void rope_usage(const vis_scene *s, uint64_t used[VIS_MAX_SHORT_STACK + 1])
{
    memset(used, 0, (VIS_MAX_SHORT_STACK + 1) * sizeof *used);
    if (!s->rope_index || s->node_count == 0)
        return;
    struct {
        uint32_t node, parent_height;
    } stack[2 * 64];
    uint32_t sp = 0;
    stack[sp].node = 0;
    stack[sp].parent_height = VIS_MAX_SHORT_STACK + 1; /* the root has no parent */
    ++sp;
    while (sp > 0) {
        --sp;
        uint32_t node = stack[sp].node, parent_h = stack[sp].parent_height;
        uint32_t e = s->rope_index[node];
        uint32_t h = e == VIS_NO_ROPE ? VIS_MAX_SHORT_STACK + 1 : s->ropes[e].height;
        for (uint32_t n = h; n < parent_h && n <= VIS_MAX_SHORT_STACK; ++n)
            used[n] += sizeof(vis_rope_node);
        uint32_t info = s->nodes[node].info;
        if ((info & 3u) == VIS_NODE_LEAF || sp + 2 > sizeof stack / sizeof stack[0])
            continue;
        for (uint32_t c = 0; c < 2; ++c) {
            stack[sp].node = (info >> 2) + c;
            stack[sp].parent_height = h;
            ++sp;
        }
    }
}

vis_status vis_scene_get_stats(const vis_scene *s, vis_scene_stats *out)
{
    if (!s || !out)
        return VIS_ERROR_INVALID_ARGUMENT;
    vis_scene_begin_read(s);
    memset(out, 0, sizeof *out);
    out->relocations = s->relocations;
    out->quad_slots = s->quad_used;
    out->tri_slots = s->tri_used;
    for (uint32_t i = 0; i < s->leaf_count; ++i) {
        out->quads_in_leaves += (uint64_t)s->leaves[i].quad_count + s->leaves[i].loose_count;
        out->tris_in_leaves += s->leaves[i].tri_count;
    }
    /* Ropes (kdtree.c): entries of the nodes up to VIS_MAX_SHORT_STACK levels high, an index
     * per node. */
    out->rope_bytes = (uint64_t)s->rope_count * sizeof *s->ropes + (uint64_t)s->node_count * sizeof *s->rope_index;
    rope_usage(s, out->rope_bytes_used);
    vis_scene_end_read(s);
    return VIS_OK;
}
