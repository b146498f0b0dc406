/* scene.h — internal: the scene (fixed-depth kd-tree, leaf pools, objects). */
#ifndef VIS_SCENE_H
#define VIS_SCENE_H

#include "backend.h"
#include "context.h"

/* An object as the host keeps it: its primitives ready to copy into leaves. */
typedef struct vis_object_host {
    uint32_t id;              /* 0: free slot                                              */
    float box_lo[3], box_hi[3];
    vis_flat_quad *quads;     /* meta already holds this object's slot index               */
    uint32_t quad_count, quad_cap;
    vis_flat_tri *tris;
    uint32_t tri_count, tri_cap;
} vis_object_host;

/* Per-leaf host bookkeeping (not sent to devices). */
typedef struct vis_leaf_host {
    uint32_t quad_slot;       /* slot start in the quad pool                                 */
    uint32_t quad_cap;        /* slot capacity in the quad pool (bucketed + loose)          */
    uint32_t tri_cap;         /* slot capacity in the triangle pool                          */
    uint32_t *objects;        /* object slots referenced by the leaf, ascending              */
    uint32_t object_count, object_cap;
    int dirty;                /* listed in dirty_leaves                                      */
} vis_leaf_host;

struct vis_scene {
    vis_context *ctx;
    vis_scene_desc desc;      /* with defaults filled in                                     */
    uint32_t kd_depth;

    vis_kd_node *nodes;
    uint32_t node_count;
    vis_flat_leaf *leaves;
    vis_leaf_host *leaf_host;
    uint32_t leaf_count;
    vis_rope_node *ropes;     /* rope nodes (built with the tree), see trace_core.h         */
    uint32_t rope_count;
    uint32_t *rope_index;     /* node -> rope entry or VIS_NO_ROPE                           */
    uint32_t *buckets;        /* per-leaf bucket tables, allocated on first use              */
    uint32_t bucket_count, bucket_cap;

    vis_flat_quad *quads;     /* pool of leaf slots                                          */
    uint32_t quad_used, quad_cap;
    vis_flat_tri *tris;
    uint32_t tri_used, tri_cap;

    vis_flat_object *objects; /* slots, index = meta object index                            */
    vis_object_host *object_host;
    uint32_t object_slots, object_cap, object_live;
    uint32_t *free_slots;
    uint32_t free_count, free_cap;
    uint32_t *object_leaves;
    uint32_t object_leaf_used, object_leaf_cap;

    uint32_t *id_map;         /* open addressing: ID -> slot + 1 (0 empty)                    */
    uint32_t id_map_cap;      /* power of two                                                */
    uint32_t max_id;

    uint64_t quad_total, tri_total, edits, relocations;

    /* Changes since the backend's last sync. */
    uint64_t generation;
    int dirty_full;
    uint32_t *dirty_leaves;
    uint32_t dirty_leaf_count;
    uint32_t *dirty_objects;
    uint32_t dirty_object_count, dirty_object_cap;
    uint8_t *object_dirty_flag;
    uint32_t dirty_ol_lo, dirty_ol_hi;

    void *backend_data;       /* the context backend's copy of this scene                    */
    uint64_t synced_generation;
};

vis_scene_view vis_scene_get_view(const vis_scene *scene);

/* Brings the context backend's copy up to date (no-op when nothing changed). */
vis_status vis_scene_sync_backend(vis_scene *scene);

/* Object slot of an ID, or VIS_NO_OBJECT. */
uint32_t vis_scene_find(const vis_scene *scene, uint32_t id);

#endif
