/* occupancy.c — see occupancy.h. */
#include "cpu/occupancy.h"

void vis_occupancy_free(vis_occupancy *occ)
{
    vis_host_free(occ->alloc, occ->parent);
    vis_host_free(occ->alloc, occ->leaf_node);
    vis_host_free(occ->alloc, occ->occupied);
    occ->parent = occ->leaf_node = NULL;
    occ->occupied = NULL;
    occ->node_count = occ->leaf_count = 0;
}

/* Parent links and leaf nodes, and every node's flag from its leaves. kdtree.c allocates
 * children after their parent, so one backward sweep sees children before parents. */
static vis_status rebuild(vis_occupancy *occ, const vis_scene_view *view)
{
    vis_occupancy_free(occ);
    uint32_t n = view->node_count;
    occ->parent = vis_host_alloc(occ->alloc, (size_t)n * sizeof *occ->parent);
    occ->leaf_node = vis_host_alloc(occ->alloc, (size_t)view->leaf_count * sizeof *occ->leaf_node);
    occ->occupied = vis_host_alloc(occ->alloc, n);
    if (!occ->parent || !occ->leaf_node || !occ->occupied) {
        vis_occupancy_free(occ);
        return VIS_ERROR_OUT_OF_MEMORY;
    }
    occ->node_count = n;
    occ->leaf_count = view->leaf_count;
    if (n)
        occ->parent[0] = UINT32_MAX;
    for (uint32_t i = 0; i < n; ++i) {
        uint32_t info = view->nodes[i].info;
        if ((info & 3u) == VIS_NODE_LEAF) {
            occ->leaf_node[info >> 2] = i;
        } else {
            occ->parent[info >> 2] = i;
            occ->parent[(info >> 2) + 1u] = i;
        }
    }
    for (uint32_t i = n; i-- > 0;) {
        uint32_t info = view->nodes[i].info;
        if ((info & 3u) == VIS_NODE_LEAF)
            occ->occupied[i] = (uint8_t)vis_leaf_has_primitives(&view->leaves[info >> 2]);
        else
            occ->occupied[i] = occ->occupied[info >> 2] | occ->occupied[(info >> 2) + 1u];
    }
    return VIS_OK;
}

vis_status vis_occupancy_sync(vis_occupancy *occ, const vis_scene_view *view, const vis_scene_changes *changes)
{
    if (changes->full || !occ->occupied || occ->node_count != view->node_count ||
        occ->leaf_count != view->leaf_count)
        return rebuild(occ, view);
    for (uint32_t i = 0; i < changes->leaf_count; ++i) {
        uint32_t node = occ->leaf_node[changes->leaves[i]];
        uint8_t flag = (uint8_t)vis_leaf_has_primitives(&view->leaves[changes->leaves[i]]);
        /* Up the tree while a flag changes; an ancestor's flag is the OR of its children. */
        while (node != UINT32_MAX && occ->occupied[node] != flag) {
            occ->occupied[node] = flag;
            node = occ->parent[node];
            if (node == UINT32_MAX)
                break;
            uint32_t first = view->nodes[node].info >> 2;
            flag = occ->occupied[first] | occ->occupied[first + 1u];
        }
    }
    return VIS_OK;
}
