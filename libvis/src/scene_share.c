/* scene_share.c — one scene, many threads and contexts: the reader-writer lock that traces
 * share and edits take alone, each context's backend copy of the scene, and the staged
 * edits that vis_scene_commit publishes (the commit model of Embree's rtcCommitScene). */
#define _GNU_SOURCE /* pthread_rwlockattr_setkind_np: writers must not starve behind traces */
#include <pthread.h>
#include <string.h>

#include "kdtree.h"
#include "scene.h"

struct vis_scene_lock {
    pthread_rwlock_t rw;
};

vis_status vis_scene_lock_init(vis_scene *s)
{
    pthread_rwlockattr_t attr;
    if (pthread_rwlockattr_init(&attr) != 0)
        return VIS_ERROR_OUT_OF_MEMORY;
#if defined(__GLIBC__)
    /* glibc prefers readers by default: four threads tracing back to back would hold the
     * lock shared forever and a commit would never get in. No call takes the lock twice,
     * so the non-recursive writer preference is safe. */
    pthread_rwlockattr_setkind_np(&attr, PTHREAD_RWLOCK_PREFER_WRITER_NONRECURSIVE_NP);
#endif
    struct vis_scene_lock *l = vis_alloc(s->ctx, sizeof *l);
    int rc = l ? pthread_rwlock_init(&l->rw, &attr) : -1;
    pthread_rwlockattr_destroy(&attr);
    if (rc != 0) {
        vis_free(s->ctx, l);
        return VIS_ERROR_OUT_OF_MEMORY;
    }
    s->lock = l;
    return VIS_OK;
}

void vis_scene_lock_free(vis_scene *s)
{
    if (!s->lock)
        return;
    pthread_rwlock_wrlock(&s->lock->rw); /* traces still in flight on other threads end first */
    pthread_rwlock_unlock(&s->lock->rw);
    pthread_rwlock_destroy(&s->lock->rw);
    vis_free(s->ctx, s->lock);
    s->lock = NULL;
}

void vis_scene_begin_read(const vis_scene *s) { pthread_rwlock_rdlock(&s->lock->rw); }
void vis_scene_end_read(const vis_scene *s) { pthread_rwlock_unlock(&s->lock->rw); }
static void begin_write(vis_scene *s) { pthread_rwlock_wrlock(&s->lock->rw); }
static void end_write(vis_scene *s) { pthread_rwlock_unlock(&s->lock->rw); }

/* ---- backend copies ------------------------------------------------------------------ */

/* What a backend may keep for the scene beside its arrays, within max_bytes. */
static uint64_t backend_room(const vis_scene *s)
{
    uint64_t bytes = vis_scene_bytes(s);
    return s->desc.max_bytes > bytes ? s->desc.max_bytes - bytes : 0;
}

/* The owning context's copy: incremental, from the change lists (which only it consumes). */
static vis_status sync_owner(vis_scene *s)
{
    vis_context *ctx = s->ctx;
    vis_scene_view view = vis_scene_get_view(s);
    vis_scene_changes ch;
    memset(&ch, 0, sizeof ch);
    ch.generation = s->generation;
    ch.full = s->dirty_full || !s->backend_data;
    ch.leaves = s->dirty_leaves;
    ch.leaf_count = s->dirty_leaf_count;
    ch.objects = s->dirty_objects;
    ch.object_count = s->dirty_object_count;
    ch.object_leaf_lo = s->dirty_ol_lo;
    ch.object_leaf_hi = s->dirty_ol_hi;
    ch.map_changed = s->dirty_map;
    memcpy(ch.map_lo, s->dirty_map_lo, sizeof ch.map_lo);
    memcpy(ch.map_hi, s->dirty_map_hi, sizeof ch.map_hi);
    ch.room = backend_room(s);
    char err[1024] = "";
    int st = ctx->backend.ops->scene_sync(ctx->backend.impl, &s->backend_data, &view, &ch, err, sizeof err);
    if (st != VIS_OK)
        return vis_fail(ctx, (vis_status)st, "%s backend: scene upload failed: %s", ctx->backend.ops->name, err);
    for (uint32_t i = 0; i < s->dirty_leaf_count; ++i)
        s->leaf_host[s->dirty_leaves[i]].dirty = 0;
    for (uint32_t i = 0; i < s->dirty_object_count; ++i)
        s->object_dirty_flag[s->dirty_objects[i]] = 0;
    s->dirty_leaf_count = 0;
    s->dirty_object_count = 0;
    s->dirty_ol_lo = s->dirty_ol_hi = 0;
    s->dirty_map = 0;
    s->dirty_full = 0;
    s->synced_generation = s->generation;
    return VIS_OK;
}

/* Another context's copy: the change lists belong to the owner, so it is sent whole
 * whenever it is behind (rare: scenes are edited between frames, not per trace). */
static vis_status sync_copy(vis_context *ctx, vis_scene *s, vis_scene_copy **slot)
{
    vis_scene_copy *c = *slot;
    if (!c) {
        c = vis_calloc(ctx, 1, sizeof *c);
        if (!c)
            return vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory for a copy of another context's scene");
        c->ctx = ctx;
        c->next = s->copies;
        s->copies = c;
        atomic_fetch_add(&ctx->foreign_copies, 1u);
        *slot = c;
    }
    vis_scene_view view = vis_scene_get_view(s);
    vis_scene_changes ch;
    memset(&ch, 0, sizeof ch);
    ch.generation = s->generation;
    ch.full = 1;
    ch.copy = 1;
    ch.room = backend_room(s);
    char err[1024] = "";
    int st = ctx->backend.ops->scene_sync(ctx->backend.impl, &c->data, &view, &ch, err, sizeof err);
    if (st != VIS_OK)
        return vis_fail(ctx, (vis_status)st, "%s backend: scene upload failed: %s", ctx->backend.ops->name, err);
    c->synced_generation = s->generation;
    return VIS_OK;
}

static vis_scene_copy *find_copy(const vis_scene *s, const vis_context *ctx)
{
    for (vis_scene_copy *c = s->copies; c; c = c->next)
        if (c->ctx == ctx)
            return c;
    return NULL;
}

/* Builds the ropes for the first pass that walks them. Every backend copy is then behind:
 * its next sync takes them (the owner's from its change lists, which hold no edit, others
 * whole). */
static vis_status build_ropes(vis_context *ctx, vis_scene *s)
{
    if (s->ropes)
        return VIS_OK; /* built by an earlier pass: no copy is behind for them */
    vis_status st = vis_kdtree_build_ropes(s, ctx);
    if (st != VIS_OK || !s->ropes)
        return st;
    s->synced_generation = s->generation - 1u;
    for (vis_scene_copy *c = s->copies; c; c = c->next)
        c->synced_generation = s->generation - 1u;
    return VIS_OK;
}

vis_status vis_scene_begin_trace(vis_context *ctx, vis_scene *s, int ropes, void **backend_data,
                                 uint64_t *upload_bytes)
{
    *upload_bytes = 0;
    for (;;) {
        vis_scene_begin_read(s);
        void *data;
        int current;
        if (s->ctx == ctx) {
            data = s->backend_data;
            current = data && s->synced_generation == s->generation;
        } else {
            vis_scene_copy *c = find_copy(s, ctx);
            data = c ? c->data : NULL;
            current = c && c->data && c->synced_generation == s->generation;
        }
        if (current && (!ropes || s->ropes)) {
            *backend_data = data;
            return VIS_OK; /* the lock stays shared until vis_scene_end_read */
        }
        vis_scene_end_read(s);
        /* The copy is behind, or the pass needs ropes the scene has not built: bring it up
         * under the exclusive lock, then look again (a commit may come in between; the loop
         * ends when none does). */
        begin_write(s);
        vis_status st = ropes ? build_ropes(ctx, s) : VIS_OK;
        void **data_slot = NULL;
        if (st == VIS_OK && s->ctx == ctx) {
            if (!(s->backend_data && s->synced_generation == s->generation)) {
                st = sync_owner(s);
                data_slot = &s->backend_data;
            }
        } else if (st == VIS_OK) {
            vis_scene_copy *c = find_copy(s, ctx);
            if (!(c && c->data && c->synced_generation == s->generation)) {
                st = sync_copy(ctx, s, &c);
                data_slot = c ? &c->data : NULL;
            }
        }
        if (st == VIS_OK && data_slot && ctx->backend.ops->last_upload_bytes)
            *upload_bytes += ctx->backend.ops->last_upload_bytes(ctx->backend.impl, *data_slot);
        end_write(s);
        if (st != VIS_OK)
            return st;
    }
}

/* ---- staged edits -------------------------------------------------------------------- */

static void free_staged_mesh(vis_context *ctx, vis_staged_edit *e)
{
    vis_free(ctx, (void *)e->mesh.quads);
    vis_free(ctx, (void *)e->mesh.triangles);
    memset(&e->mesh, 0, sizeof e->mesh);
}

static vis_status stage(vis_scene *s, uint32_t id, const vis_mesh *mesh)
{
    vis_context *ctx = s->ctx;
    if (s->staged_count == s->staged_cap) {
        uint32_t cap = s->staged_cap ? s->staged_cap * 2 : 16;
        if (cap < s->staged_cap)
            return vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "too many staged edits");
        vis_staged_edit *p = vis_realloc(ctx, s->staged, (size_t)s->staged_cap * sizeof *p, (size_t)cap * sizeof *p);
        if (!p)
            return vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory staging an edit");
        s->staged = p;
        s->staged_cap = cap;
    }
    vis_staged_edit e;
    memset(&e, 0, sizeof e);
    e.id = id;
    e.remove = mesh == NULL;
    if (mesh) {
        vis_quad *q = mesh->quad_count ? vis_alloc(ctx, (size_t)mesh->quad_count * sizeof *q) : NULL;
        vis_triangle *t = mesh->triangle_count ? vis_alloc(ctx, (size_t)mesh->triangle_count * sizeof *t) : NULL;
        if ((mesh->quad_count && !q) || (mesh->triangle_count && !t)) {
            vis_free(ctx, q);
            vis_free(ctx, t);
            return vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory staging the mesh of object %u", id);
        }
        if (q)
            memcpy(q, mesh->quads, (size_t)mesh->quad_count * sizeof *q);
        if (t)
            memcpy(t, mesh->triangles, (size_t)mesh->triangle_count * sizeof *t);
        e.mesh.quads = q;
        e.mesh.quad_count = mesh->quad_count;
        e.mesh.triangles = t;
        e.mesh.triangle_count = mesh->triangle_count;
    }
    s->staged[s->staged_count++] = e;
    return VIS_OK;
}

/* Whether the object exists once the staged edits are applied. Only the owning context's
 * thread changes the ID map, and this runs on it: reading without the lock is safe. */
static int exists_staged(const vis_scene *s, uint32_t id)
{
    for (uint32_t i = s->staged_count; i-- > 0;)
        if (s->staged[i].id == id)
            return !s->staged[i].remove && (s->staged[i].mesh.quad_count || s->staged[i].mesh.triangle_count);
    return vis_scene_find(s, id) != VIS_NO_OBJECT;
}

/* The entry of the scene's public calls: a scene, its context entered, the error cleared. */
static vis_status scene_enter(vis_scene *s)
{
    if (!s)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(s->ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_clear_error(s->ctx);
    return VIS_OK;
}

/* Set (mesh) or remove (remove != 0) an object: staged under VIS_COMMIT_EXPLICIT, else applied
 * now. */
static vis_status edit_object(vis_scene *s, uint32_t id, const vis_mesh *mesh, int remove)
{
    vis_status st = scene_enter(s);
    if (st != VIS_OK)
        return st;
    vis_context *ctx = s->ctx;
    if (s->desc.commit == VIS_COMMIT_EXPLICIT) {
        if (remove) {
            st = exists_staged(s, id) ? stage(s, id, NULL)
                                      : vis_fail(ctx, VIS_ERROR_NOT_FOUND, "no object with ID %u", id);
        } else {
            st = vis_scene_check_mesh(s, id, mesh);
            if (st == VIS_OK)
                st = stage(s, id, mesh);
        }
    } else {
        begin_write(s);
        st = remove ? vis_scene_apply_remove(s, id) : vis_scene_apply_set(s, id, mesh);
        end_write(s);
    }
    vis_leave(ctx);
    return st;
}

vis_status vis_scene_set_object(vis_scene *s, uint32_t id, const vis_mesh *mesh)
{
    return edit_object(s, id, mesh, 0);
}

vis_status vis_scene_remove_object(vis_scene *s, uint32_t id)
{
    return edit_object(s, id, NULL, 1);
}

vis_status vis_scene_commit(vis_scene *s)
{
    vis_status st = scene_enter(s);
    if (st != VIS_OK)
        return st;
    vis_context *ctx = s->ctx;
    if (s->staged_count) {
        begin_write(s);
        for (uint32_t i = 0; i < s->staged_count; ++i) {
            vis_staged_edit *e = &s->staged[i];
            if (st == VIS_OK)
                st = e->remove ? vis_scene_apply_remove(s, e->id) : vis_scene_apply_set(s, e->id, &e->mesh);
            free_staged_mesh(ctx, e);
        }
        s->staged_count = 0;
        end_write(s);
    }
    vis_leave(ctx);
    return st;
}

void vis_scene_share_free(vis_scene *s)
{
    for (uint32_t i = 0; i < s->staged_count; ++i)
        free_staged_mesh(s->ctx, &s->staged[i]);
    vis_free(s->ctx, s->staged);
    s->staged = NULL;
    s->staged_count = s->staged_cap = 0;
    while (s->copies) {
        vis_scene_copy *c = s->copies;
        s->copies = c->next;
        if (c->data && c->ctx->backend.ops->scene_release)
            c->ctx->backend.ops->scene_release(c->ctx->backend.impl, c->data);
        atomic_fetch_sub(&c->ctx->foreign_copies, 1u);
        vis_free(c->ctx, c);
    }
}
