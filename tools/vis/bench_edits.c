/* bench_edits.c — `vis bench` edits: random single-voxel toggles near the surface, each
 * applied and timed as a game would (vw_world_set, then the remesh of the dirty chunks and
 * the in-place leaf update of world_scene_update), next to Embree's dynamic-scene update. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"
#include "timer.h"

typedef struct touched {
    uint32_t *chunks;
    uint32_t *ids;
    size_t count, cap;
} touched;

static void note_chunk(uint32_t chunk, uint32_t id, const vw_mesh *mesh, void *user)
{
    (void)mesh;
    touched *t = user;
    if (t->count < t->cap) {
        t->chunks[t->count] = chunk;
        t->ids[t->count] = id;
        ++t->count;
    }
}

static uint64_t splitmix64(uint64_t *s)
{
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* The Embree side of one edit: remesh the touched chunks (untimed, as for us the remesh is
 * shared work), then replace their geometries and recommit (timed). */
/* The touched chunk's mesh as libvis quads (empty when the chunk emptied). Returns the
 * quad count, or (size_t)-1 when the conversion buffer cannot grow. */
static size_t chunk_quads(bench *b, uint32_t chunk, vw_mesh *mesh, vis_quad **quads, size_t *cap)
{
    mesh->count = 0;
    if (!vw_world_chunk_empty(b->world.world, chunk) && vw_mesh_chunk(b->world.world, chunk, mesh) != VW_OK)
        mesh->count = 0;
    if (mesh->count > *cap) {
        vis_quad *q = realloc(*quads, mesh->count * 2 * sizeof *q);
        if (!q)
            return (size_t)-1;
        *quads = q;
        *cap = mesh->count * 2;
    }
    world_scene_convert_quads(mesh->quads, mesh->count, *quads);
    return mesh->count;
}

static double embree_edit(bench *b, const touched *t, vw_mesh *mesh, vis_quad **quads, size_t *cap)
{
    double ms = 0.0;
    for (size_t i = 0; i < t->count; ++i) {
        size_t n = chunk_quads(b, t->chunks[i], mesh, quads, cap);
        if (n == (size_t)-1)
            return ms;
        ms += embree_compare_replace(b->ec, t->ids[i], *quads, n);
    }
    return ms + embree_compare_commit(b->ec);
}

/* An OpenCL copy of the scene that mirrors every edit, to measure what one edit sends to the
 * device: the changed leaves and objects only (docs/opencl.md). Absent without a device. */
typedef struct upload_mirror {
    vis_context *ctx;
    world_scene *ws;
    char device[128];
} upload_mirror;

static uint64_t mirror_sync(upload_mirror *m);

static void mirror_open(bench *b, upload_mirror *m)
{
    memset(m, 0, sizeof *m);
    vis_context_desc cd;
    vis_context_desc_defaults(&cd);
    cd.backend = VIS_BACKEND_OPENCL;
    if (vis_context_create(&cd, &m->ctx) != VIS_OK) {
        m->ctx = NULL;
        return;
    }
    vis_backend_info bi;
    vis_context_backend(m->ctx, &bi);
    snprintf(m->device, sizeof m->device, "%s", bi.device);
    world_scene_options o;
    memset(&o, 0, sizeof o);
    o.kd_depth = b->a->kd_depth;
    vw_error err;
    /* The first sync sends the whole scene; only what follows it is per edit. */
    if (world_scene_create(m->ctx, b->world.world, &o, &m->ws, NULL, &err) != 0 || mirror_sync(m) == UINT64_MAX) {
        world_scene_destroy(m->ws);
        vis_context_destroy(m->ctx);
        m->ctx = NULL;
        m->ws = NULL;
    }
}

static void mirror_close(upload_mirror *m)
{
    world_scene_destroy(m->ws);
    vis_context_destroy(m->ctx);
}

/* Brings the device copy up to date with a 1x1 pass; returns the bytes that sync uploaded
 * (UINT64_MAX on failure). */
static uint64_t mirror_sync(upload_mirror *m)
{
    vis_scene *s = world_scene_scene(m->ws);
    vis_scene_info info;
    vis_scene_get_info(s, &info);
    vis_camera cam = {{0, 0, 0}, {info.size[0], info.size[1], info.size[2]}, 60, 0, 0};
    for (int a = 0; a < 3; ++a) {
        cam.eye[a] = info.origin[a] - 1.0;
        cam.target[a] += info.origin[a];
    }
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = td.height = 1;
    uint32_t id;
    vis_timing timing;
    if (vis_trace(m->ctx, s, &cam, &td, &id, 1, NULL, 0) != VIS_OK || vis_context_last_timing(m->ctx, &timing) != VIS_OK)
        return UINT64_MAX;
    return timing.upload_bytes;
}

/* Applies the touched chunks to the mirror and returns what the next sync uploads. */
static uint64_t mirror_edit(bench *b, upload_mirror *m, const touched *t, vw_mesh *mesh, vis_quad **quads,
                            size_t *cap)
{
    vis_scene *s = world_scene_scene(m->ws);
    for (size_t i = 0; i < t->count; ++i) {
        size_t n = chunk_quads(b, t->chunks[i], mesh, quads, cap);
        if (n == (size_t)-1)
            return UINT64_MAX;
        vis_mesh vm = {*quads, (uint32_t)n, NULL, 0};
        if (vis_scene_set_object(s, t->ids[i], &vm) != VIS_OK)
            return UINT64_MAX;
    }
    return mirror_sync(m);
}

int bench_run_edits(bench *b)
{
    const cli_args *a = b->a;
    uint32_t k = a->edits;
    edit_result *er = &b->edits;
    memset(er, 0, sizeof *er);
    er->count = k;
    if (k == 0)
        return CLI_EXIT_OK;
    vw_world *w = b->world.world;
    vw_world_info wi;
    vw_world_get_info(w, &wi);
    double *total = malloc(k * sizeof *total), *update = malloc(k * sizeof *update);
    double *remesh = malloc(k * sizeof *remesh), *emb = malloc(k * sizeof *emb);
    double *upload = malloc(k * sizeof *upload), *sync = malloc(k * sizeof *sync);
    upload_mirror mirror;
    mirror_open(b, &mirror);
    touched t = {0};
    t.cap = 64;
    t.chunks = malloc(t.cap * sizeof *t.chunks);
    t.ids = malloc(t.cap * sizeof *t.ids);
    vw_mesh mesh = {0};
    vis_quad *quads = NULL;
    size_t quad_cap = 0;
    int rc = CLI_EXIT_OK;
    if (!total || !update || !remesh || !emb || !upload || !sync || !t.chunks || !t.ids) {
        rc = cli_fail(CMD, "out of memory");
        goto done;
    }
    world_scene_set_chunk_hook(b->keep.ws, note_chunk, &t);
    uint64_t rng = a->seed;
    uint64_t chunks = 0;
    double sum_ms = 0.0;
    for (uint32_t i = 0; i < k; ++i) {
        /* A voxel near the surface: remove the top voxel of a random column, or add one on it. */
        int64_t x = wi.origin[0] + (int64_t)(splitmix64(&rng) % (uint64_t)wi.size[0]);
        int64_t z = wi.origin[2] + (int64_t)(splitmix64(&rng) % (uint64_t)wi.size[2]);
        int64_t top = vc_surface_height(w, x, z);
        int64_t y;
        vw_voxel value;
        int remove = (splitmix64(&rng) & 1) && top > wi.origin[1];
        if (top >= wi.origin[1] + wi.size[1])
            remove = 1;
        if (remove) {
            y = top - 1;
            value = 0;
        } else {
            y = top;
            value = top > wi.origin[1] ? vw_world_get(w, x, top - 1, z) : 1;
            if (!value)
                value = 1;
        }
        t.count = 0;
        world_scene_stats st;
        vw_error err;
        double t0 = vc_now_ms();
        vw_status vs = vw_world_set(w, x, y, z, value);
        if (vs != VW_OK) {
            rc = cli_fail(CMD, "vw_world_set(%lld, %lld, %lld): %s", (long long)x, (long long)y, (long long)z,
                          vw_status_string(vs));
            goto done;
        }
        if (world_scene_update(b->keep.ws, &st, &err) != 0) {
            rc = cli_fail(CMD, "edit %u: %s", i, err.message);
            goto done;
        }
        total[i] = vc_now_ms() - t0;
        update[i] = st.scene_ms;
        remesh[i] = st.mesh_ms;
        /* What the next pass pays for the edit before its rays: the backend's copy brought up
         * to date (the CPU: the changed leaves' voxel labels and subtree fills). */
        double s0 = vc_now_ms();
        if (vis_scene_prepare(b->keep.ctx, world_scene_scene(b->keep.ws)) != VIS_OK) {
            rc = cli_fail_vis(CMD, b->keep.ctx, "vis_scene_prepare");
            goto done;
        }
        sync[i] = vc_now_ms() - s0;
        sum_ms += total[i];
        chunks += st.chunks;
        if (b->ec)
            emb[i] = embree_edit(b, &t, &mesh, &quads, &quad_cap);
        if (mirror.ctx) {
            uint64_t bytes = mirror_edit(b, &mirror, &t, &mesh, &quads, &quad_cap);
            if (bytes == UINT64_MAX) {
                rc = cli_fail(CMD, "edit %u on the OpenCL copy: %s", i, vis_context_last_error(mirror.ctx));
                goto done;
            }
            upload[i] = (double)bytes;
        }
    }
    if (mirror.ctx) {
        er->upload = 1;
        snprintf(er->upload_device, sizeof er->upload_device, "%s", mirror.device);
        er->upload_median_bytes = vc_median(upload, k);
        er->upload_max_bytes = vc_max(upload, k);
        vis_scene_info mi;
        vis_scene_get_info(world_scene_scene(mirror.ws), &mi);
        er->scene_bytes = (double)mi.bytes;
    }
    /* Memory after the edits against a fresh build of the edited world (freed leaf slots are
     * reused: the two should stay close however many edits ran). */
    {
        vis_scene_info ei, fi;
        world_scene *fresh = NULL;
        world_scene_options o;
        memset(&o, 0, sizeof o);
        o.kd_depth = a->kd_depth;
        vw_error err;
        if (vis_scene_get_info(world_scene_scene(b->keep.ws), &ei) == VIS_OK &&
            world_scene_create(b->keep.ctx, w, &o, &fresh, NULL, &err) == 0 &&
            vis_scene_get_info(world_scene_scene(fresh), &fi) == VIS_OK) {
            er->edited_bytes = ei.bytes;
            er->fresh_bytes = fi.bytes;
        }
        if (fresh)
            world_scene_destroy(fresh);
    }
    er->per_s = sum_ms > 0.0 ? (double)k / (sum_ms / 1e3) : 0.0;
    er->chunks_per_edit = (double)chunks / (double)k;
    er->max_ms = vc_max(total, k);
    er->p99_ms = vc_percentile(total, k, 99.0);
    er->median_ms = vc_median(total, k);
    er->update_median_ms = vc_median(update, k);
    er->remesh_median_ms = vc_median(remesh, k);
    er->sync_median_ms = vc_median(sync, k);
    er->sync_max_ms = vc_max(sync, k);
    if (b->ec) {
        er->embree = 1;
        er->embree_p99_ms = vc_percentile(emb, k, 99.0);
        er->embree_median_ms = vc_median(emb, k);
    }
    if (!a->json) {
        printf("\nedits: %u random single-voxel edits near the surface (%.2f chunks remeshed per edit)\n", k,
               er->chunks_per_edit);
        printf("  ours      median %.4f ms, p99 %.4f ms, max %.4f ms, %.0f edits/s "
               "(remesh median %.4f ms, leaf update median %.4f ms)\n",
               er->median_ms, er->p99_ms, er->max_ms, er->per_s, er->remesh_median_ms, er->update_median_ms);
        printf("  next pass the backend's copy brought up to date (%s): median %.4f ms, max %.4f ms\n",
               b->keep.backend.name, er->sync_median_ms, er->sync_max_ms);
        if (er->embree)
            printf("  embree    dynamic scene, replace geometry + rtcCommitScene: median %.4f ms, p99 %.4f ms "
                   "(remesh not included)\n",
                   er->embree_median_ms, er->embree_p99_ms);
        if (er->fresh_bytes)
            printf("  memory    edited scene %.2f MB, a fresh build of the edited world %.2f MB (%+.1f %%)\n",
                   (double)er->edited_bytes / 1e6, (double)er->fresh_bytes / 1e6,
                   100.0 * ((double)er->edited_bytes / (double)er->fresh_bytes - 1.0));
        if (er->upload)
            printf("  opencl    bytes uploaded per edit (%s): median %.0f, max %.0f (the host scene holds %.0f)\n",
                   er->upload_device, er->upload_median_bytes, er->upload_max_bytes, er->scene_bytes);
        else
            printf("  opencl    bytes uploaded per edit: no OpenCL device in this build or machine\n");
    }
done:
    world_scene_set_chunk_hook(b->keep.ws, NULL, NULL);
    free(total);
    free(update);
    free(remesh);
    free(emb);
    free(upload);
    free(sync);
    if (mirror.ctx)
        mirror_close(&mirror);
    free(t.chunks);
    free(t.ids);
    free(quads);
    vw_mesh_free(&mesh);
    return rc;
}

