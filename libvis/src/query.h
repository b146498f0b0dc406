/* query.h — internal: the server query object (query.c runs a tick, query_chunks.c traces the
 * chunk passes, occlusion.c proves entities hidden). */
#ifndef VIS_QUERY_H
#define VIS_QUERY_H

#include "context.h"
#include "cpu/threadpool.h"
#include "occlusion.h"
#include "scene.h"

/* ID -> slot, open addressing, capacity a power of two at least twice the entries. */
typedef struct vis_idmap {
    uint32_t *keys;  /* 0: empty */
    uint32_t *vals;
    uint32_t mask;
} vis_idmap;

/* One viewer's slot: kept across ticks while its ID comes back. */
typedef struct vis_qviewer {
    uint32_t id;              /* 0: free                                                   */
    uint32_t chunk_count;     /* entries of its chunk list: the union of its faces' IDs     */
    double chunk_eye[3];      /* the camera when its last round of faces became due: eye,   */
    double chunk_dir[3];      /* dir, fov_deg (chunk_move and the skip of an unchanged       */
    double chunk_fov;         /* camera compare with them)                                  */
    uint32_t chunk_faces;     /* faces of its pass (6 all around, 1 in view; 0: none yet);  */
                              /* each face's ray setup, depths and IDs are kept (chunk_setup, */
                              /* chunk_depth, face_ids)                                      */
    uint32_t face_count[6];   /* unique IDs of each face (face_ids)                          */
    uint64_t face_tick[6];    /* tick each face was last traced (0: never)                   */
    uint8_t face_owed[6];     /* 0, or 1 + why the face was due on a call whose
                                 chunk_face_budget left it untraced: due until traced        */
} vis_qviewer;

typedef struct vis_qentity {
    uint32_t id;
} vis_qentity;

/* What one viewer's job produced this tick. */
typedef struct vis_qresult {
    uint32_t hit_count;
    uint32_t pairs, cached, seen, hidden, unchecked, held;
    uint64_t rays;
    uint64_t solid_tests;     /* boxes asked of desc.solid                                  */
    uint32_t next;            /* its next pair to prove, by position in its priority order  */
    uint64_t demand;          /* the most its pairs from next on may spend (pair limits)    */
    uint64_t budget;          /* rays it may spend in this round of proofs                  */
} vis_qresult;

struct vis_query {
    vis_context *ctx;
    vis_scene *scene;
    vis_query_desc desc;      /* defaults filled in                                         */
    vis_pool *pool;           /* NULL: serial, the context's parallel_for or its CPU threads */
    int cpu_threads;          /* the viewers run on the CPU backend's own threads           */
    vis_parallel_for_fn parallel_for;
    void *parallel_for_user;
    uint64_t tick;
    uint64_t generation;      /* the scene's at the last tick                               */
    int regenerated;          /* this tick: the scene changed since the last                */

    vis_qviewer *viewers;     /* max_viewers slots                                          */
    vis_qentity *entities;    /* max_entities slots                                         */
    vis_idmap viewer_map, entity_map;  /* ID -> slot of the last tick                       */
    vis_idmap check_map;      /* this tick's IDs, for duplicates                            */
    uint32_t *vslot, *eslot;  /* this tick: input index -> slot                             */
    uint32_t last_viewers;    /* viewers of the last successful run                         */
    uint8_t *pair_state;      /* [viewer slot * max_entities + entity slot]: cached result  */
    vis_occ_box *pair_eye;    /* and the regions it covers (same index): HIDDEN, every
                                 segment from pair_eye to pair_box is blocked; SEEN, the
                                 segment from pair_eye.lo to pair_box.lo is unblocked      */
    vis_occ_box *pair_box;
    uint32_t *pair_seen;      /* tick seen + 1 (0: never), for the hold                      */
    uint32_t *pair_retry;     /* UNSETTLED pairs: the tick from which they are proven again  */

    /* This tick's inputs, converted (input order). */
    const vis_query_viewer *in_viewers;
    const vis_query_entity *in_entities;
    uint32_t viewer_count, entity_count;
    vis_occ_box *eye_now;     /* max_viewers                                                */
    vis_occ_box *box_now;     /* max_viewers * max_entities: each viewer's swept boxes      */

    uint64_t *keys;           /* max_viewers * max_entities: each viewer's priority order    */
    uint64_t *share_order;    /* max_viewers: the call budget's viewers by demand (query.c)  */
    int viewer_step;          /* what this run of the viewers' jobs does (query.c)          */
    vis_query_hit *hits;      /* max_viewers * max_entities: each viewer's list (input order) */
    vis_qresult *results;     /* max_viewers                                                */
    vis_scene_view view;      /* the entity phase's view of the scene (its lock held)       */

    /* Chunk passes. */
    uint32_t chunk_cap;       /* 6 * chunk_res^2: the most distinct IDs one viewer's pass has */
    uint32_t *chunks;         /* max_viewers * chunk_cap, by viewer slot: the lists          */
    uint32_t *face_ids;       /* max_viewers * chunk_cap, by viewer slot: chunk_res^2 per face */
    vis_camera *cameras;      /* max_viewers * 6                                            */
    uint32_t *ids;            /* max_viewers * 6 * chunk_res^2                              */
    vis_idmap chunk_set;      /* dedup of one face, or of one viewer's faces                */
    uint32_t chunk_passes;    /* viewers with a face traced this tick                       */
    uint64_t chunk_rays;
    uint32_t chunk_deferred;  /* due faces the face budget left for a later tick             */
    uint8_t *face_due;        /* max_viewers * 6, by input index: 0, or 1 + why a face is due */
    uint64_t *face_keys;      /* max_viewers * 6: this tick's due faces, in budget order     */
    uint8_t *viewer_flags;    /* max_viewers, by input index (query_chunks.c)               */

    /* Edits: which passes an edit can change (query_chunks.c). Each slot keeps its last pass's
     * ray setups and per-pixel hit distances; the boxes the scene changed since the last tick
     * are tested against them, and only passes with a ray that reaches one are traced again. */
    vis_ray_setup *chunk_setup; /* max_viewers * 6, by viewer slot and face                 */
    float *chunk_depth;       /* max_viewers * chunk_cap, by viewer slot: chunk_res^2 per face */
    float *depth;             /* max_viewers * 6 * chunk_res^2: the batch's hit distances   */
    vis_ray_setup *setups;    /* max_viewers * 6: the batch's ray setups                    */
    vis_scene_edit_box changes[VIS_SCENE_EDIT_LOG]; /* this tick's changed boxes            */
    uint32_t change_count;    /* UINT32_MAX: the log did not reach back (retrace everyone)  */
    uint32_t chunk_edit_passes; /* this tick's viewers with a face traced because of an edit */
};

/* The faces of the viewer in slot s whose IDs this tick's changed boxes (q->changes,
 * q->change_count) can change, as a mask (bit f: face f): those of its traced faces with a
 * ray that reaches a changed box before its hit (query_edits.c). */
uint32_t vis_query_edit_faces(const vis_query *q, uint32_t slot);

/* Does the segment o + t d, t in [t0, t1], meet the box [lo, hi]? (Kay and Kajiya's slabs,
 * in double; query_edits.c.) */
int vis_segment_meets_box(const double o[3], const double d[3], const double lo[3], const double hi[3], double t0,
                          double t1);

/* Does the viewer look all around (dir 0: six faces) rather than in view? (query_chunks.c) */
int vis_query_all_around(const vis_query_viewer *v);

/* Readies the backend for the chunk passes, so that the first tick does not pay for it: a
 * batch of two 1x1 views with the passes' traversal, which makes an OpenCL device build the
 * batch program and take the scene's first upload (query_chunks.c). The caller holds the
 * context. */
vis_status vis_query_chunks_warm(vis_query *q);

/* Traces the chunk passes due this tick (query_chunks.c); the caller holds the context. */
vis_status vis_query_chunks_run(vis_query *q);

/* The open-addressing map (query.c). */
uint32_t vis_idmap_find(const vis_idmap *m, uint32_t key);          /* UINT32_MAX: absent  */
int vis_idmap_insert(vis_idmap *m, uint32_t key, uint32_t val);      /* 0: already there    */
void vis_idmap_clear(vis_idmap *m);

#endif
