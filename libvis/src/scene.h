/* scene.h — internal: the scene (fixed-depth kd-tree, leaf pools, objects). */
#ifndef VIS_SCENE_H
#define VIS_SCENE_H

#include "backend.h"
#include "context.h"
#include "slot_free.h"

/* Another context's backend copy of the scene (scene_share.c). */
typedef struct vis_scene_copy {
    vis_context *ctx;
    void *data;
    uint64_t synced_generation;
    struct vis_scene_copy *next;
} vis_scene_copy;

/* An edit staged for vis_scene_commit (VIS_COMMIT_EXPLICIT); the mesh is the scene's copy,
 * NULL arrays for a removal. */
typedef struct vis_staged_edit {
    uint32_t id;
    int remove;
    vis_mesh mesh;
} vis_staged_edit;

/* The boxes the last edits changed, so that a reader behind by a few generations learns
 * where the scene changed instead of only that it did (the server queries retrace only the
 * chunk passes whose rays reach one, query_chunks.c). A ring of VIS_SCENE_EDIT_LOG entries,
 * each a box and the generations first..last whose edits it covers (an edit of the box just
 * logged extends that entry instead of taking another); `floor` is the oldest generation the
 * ring still reaches back from. Fixed size inside the scene: nothing is allocated per edit. */
#define VIS_SCENE_EDIT_LOG 64u
typedef struct vis_scene_edit_box {
    uint64_t first, last;     /* generations made by the edits of this box                   */
    float lo[3], hi[3];       /* scene-local: the object's box before and after, hulled       */
} vis_scene_edit_box;

typedef struct vis_scene_edit_log {
    vis_scene_edit_box ring[VIS_SCENE_EDIT_LOG];
    uint32_t head, count;     /* next entry to write; entries held                            */
    uint64_t floor;           /* boxes changed since any generation >= floor are all held     */
} vis_scene_edit_log;

/* An object as the host keeps it: its primitives ready to copy into leaves. */
typedef struct vis_object_host {
    uint32_t id;              /* 0: free slot                                              */
    float box_lo[3], box_hi[3];
    vis_flat_quad *quads;     /* meta already holds this object's slot index               */
    uint32_t quad_count, quad_cap;
    vis_flat_tri *tris;
    uint32_t tri_count, tri_cap;
    uint32_t leaf_range;      /* entries of object_leaves the slot holds from leaf_offset      */
} vis_object_host;

/* Per-leaf host bookkeeping (not sent to devices). */
typedef struct vis_leaf_host {
    uint32_t quad_slot;       /* slot start in the quad pool (words)                         */
    uint32_t quad_cap;        /* slot capacity in the quad pool, in words                    */
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
    vis_rope_node *ropes;     /* rope nodes (NULL until a pass walks them), trace_core.h    */
    uint32_t rope_count;
    uint32_t *rope_index;     /* node -> rope entry or VIS_NO_ROPE; at full depth, then the
                                 cell map: rope_index[cell_map + cell] = the cell's leaf     */
    uint32_t cells[3];        /* the cell grid the tree splits (kdtree.c)                    */
    uint32_t cell_map;        /* node_count at full depth (every leaf one cell), else 0      */
    uint32_t *buckets;        /* per-leaf bucket tables, allocated on first use              */
    uint32_t bucket_count, bucket_cap;

    uint32_t *quads;          /* pool of leaf slots, in words (trace_core.h, vis_flat_leaf) */
    uint32_t quad_used, quad_cap;
    vis_flat_tri *tris;
    uint32_t tri_used, tri_cap;
    vis_slot_free quad_free, tri_free; /* freed leaf slots by size class (slot_free.h)         */

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
    uint64_t leaf_list_bytes;   /* sum of the leaves' object list capacities, in bytes       */
    uint64_t object_prim_bytes; /* sum of the objects' quad and triangle capacities, in bytes */

    /* Changes since the backend's last sync. */
    uint64_t generation;
    vis_scene_edit_log edit_log; /* the boxes of the last edits (scene_edit_log.c)             */
    int dirty_full;
    uint32_t *dirty_leaves;
    uint32_t dirty_leaf_count;
    uint32_t *dirty_objects;
    uint32_t dirty_object_count, dirty_object_cap;
    uint8_t *object_dirty_flag;
    uint32_t dirty_ol_lo, dirty_ol_hi;
    int dirty_map;            /* cell map entries changed (kdtree.c), all in the box below  */
    uint32_t dirty_map_lo[3], dirty_map_hi[3];

    void *backend_data;       /* the context backend's copy of this scene                    */
    uint64_t synced_generation;

    /* Sharing (scene_share.c): traces hold `lock` shared, edits that change the arrays above
     * and commits hold it exclusive. Staged edits and the context list belong to the owning
     * context (changed only by calls on it). */
    struct vis_scene_lock *lock; /* a pthread rwlock, behind a pointer so that files built
                                    with an older _POSIX_C_SOURCE need not see its type   */
    vis_scene_copy *copies;   /* other contexts' backend copies                               */
    vis_staged_edit *staged;
    uint32_t staged_count, staged_cap;
    vis_scene *ctx_prev, *ctx_next; /* ctx->scenes                                            */
};

vis_scene_view vis_scene_get_view(const vis_scene *scene);

/* Lists the leaf for the backends' next sync (dirty tracking). */
void vis_scene_mark_leaf(vis_scene *scene, uint32_t leaf);

/* Compacts the primitive pools whose freed slots have piled up (scene_compact.c). */
void vis_scene_compact_pools(vis_scene *scene);

/* Calls visit for every quad of the object in `slot`, meta holding the slot: from its copy,
 * or from its leaf where it lies in one leaf (which then holds its only copy, scene.c). */
void vis_scene_visit_object_quads(const vis_scene *scene, uint32_t slot,
                                  void (*visit)(void *user, const vis_flat_quad *q), void *user);

/* Saturating arithmetic for sizes that may not fit (plans of trees too big to build). */
static inline uint64_t vis_sat_add(uint64_t a, uint64_t b) { return a > UINT64_MAX - b ? UINT64_MAX : a + b; }
static inline uint64_t vis_sat_mul(uint64_t a, uint64_t b) { return b && a > UINT64_MAX / b ? UINT64_MAX : a * b; }

/* Bytes of an empty scene whose tree has these counts (vis_scene_info.bytes right after
 * vis_scene_create); saturates at UINT64_MAX. */
uint64_t vis_scene_tree_bytes(uint64_t nodes, uint64_t leaves, uint64_t ropes, uint64_t cell_map);

/* Host memory the scene holds now (vis_scene_info.bytes), from its capacities. */
uint64_t vis_scene_bytes(const vis_scene *scene);

/* The edits themselves, applied at once to the arrays (the caller holds the scene's lock
 * exclusive and its context). */
vis_status vis_scene_apply_set(vis_scene *scene, uint32_t id, const vis_mesh *mesh);
vis_status vis_scene_apply_remove(vis_scene *scene, uint32_t id);
/* Argument checks of vis_scene_set_object that need no lock (ID, mesh, bounds). */
vis_status vis_scene_check_mesh(vis_scene *scene, uint32_t id, const vis_mesh *mesh);

/* For a pass of `ctx` over the scene: takes the scene's lock shared, with ctx's backend copy
 * up to date (and the ropes built, for a pass that walks them), and gives the copy's data.
 * vis_scene_end_read releases the lock. */
vis_status vis_scene_begin_trace(vis_context *ctx, vis_scene *scene, int ropes, void **backend_data,
                                 uint64_t *upload_bytes);
void vis_scene_begin_read(const vis_scene *scene);
void vis_scene_end_read(const vis_scene *scene);

/* The scene's lock (vis_scene_create); vis_scene_lock_free waits for the traces in flight. */
vis_status vis_scene_lock_init(vis_scene *scene);
void vis_scene_lock_free(vis_scene *scene);

/* Releases the other contexts' copies and the staged edits (vis_scene_destroy). */
void vis_scene_share_free(vis_scene *scene);

/* Counts an edit (++generation) and logs the box it changed: the hull of the object's box
 * before (have_old) and after (have_new) the edit (scene_edit_log.c). */
void vis_scene_log_edit(vis_scene *scene, int have_old, const float old_lo[3], const float old_hi[3], int have_new,
                          const float new_lo[3], const float new_hi[3]);

/* The boxes changed since generation `since` (<= the scene's), hull by hull, into
 * out[0..capacity): their count, 0 when nothing changed, or UINT32_MAX when the log no longer
 * reaches back that far or capacity is short (the caller then treats everything as changed).
 * The caller holds the scene's lock (shared is enough). */
uint32_t vis_scene_edits_since(const vis_scene *scene, uint64_t since, vis_scene_edit_box *out, uint32_t capacity);

/* Object slot of an ID, or VIS_NO_OBJECT. */
uint32_t vis_scene_find(const vis_scene *scene, uint32_t id);

#endif
