/* cull.c — one frame of libvis: the engine's camera form in, a draw list out. */
#include "cull.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "timer.h"

const char *vv_method_name(vv_method m)
{
    switch (m) {
    case VV_METHOD_RAY_OBJECT: return "ray pass, object IDs";
    case VV_METHOD_RAY_LEAF: return "ray pass, leaf IDs";
    case VV_METHOD_ZBUF: return "z-buffer culler";
    case VV_METHOD_NONE: return "no culling";
    default: return "?";
    }
}

static int open_context(vis_backend_kind kind, vis_context **out, vis_backend_info *info, char *err, size_t err_size)
{
    vis_context_desc d;
    vis_context_desc_defaults(&d);
    d.backend = kind;
    vis_status st = vis_context_create(&d, out);
    if (st != VIS_OK) {
        snprintf(err, err_size, "cannot create a %s context: %s", kind == VIS_BACKEND_OPENCL ? "OpenCL" : "CPU",
                 vis_status_string(st));
        return -1;
    }
    if (vis_context_backend(*out, info) != VIS_OK) {
        snprintf(err, err_size, "vis_context_backend: %s", vis_context_last_error(*out));
        vis_context_destroy(*out);
        *out = NULL;
        return -1;
    }
    return 0;
}

int vv_cull_open(vv_cull *c, vw_world *world, vis_backend_kind backend, uint32_t width, uint32_t height)
{
    memset(c, 0, sizeof *c);
    char err[512];
    vis_context *ctx;
    vis_backend_info info;
    if (open_context(backend, &ctx, &info, err, sizeof err) != 0) {
        fprintf(stderr, "vis-viewer: %s\n", err);
        return VV_EXIT_FAILURE;
    }
    int slot = info.kind == VIS_BACKEND_OPENCL ? 1 : 0;
    c->ctx[slot] = ctx;
    c->info[slot] = info;
    c->owner = c->active = slot;
    size_t n = (size_t)VV_MAX_PASS * VV_MAX_PASS;
    c->ids = malloc(n * sizeof *c->ids);
    c->depth = malloc(n * sizeof *c->depth);
    c->zdepth = malloc(n * sizeof *c->zdepth);
    c->cost = malloc(n * sizeof *c->cost);
    c->cost_ids = malloc(n * sizeof *c->cost_ids);
    /* The effects' buffers too, whether or not an effect is on yet: a key turns one on in
     * the middle of a flight, and a frame allocates nothing. */
    c->see_through = malloc(n * VC_SEE_THROUGH_LAYERS * sizeof *c->see_through);
    c->reflection = malloc(n * sizeof *c->reflection);
    c->shadow = malloc(n * sizeof *c->shadow);
    if (!c->ids || !c->depth || !c->zdepth || !c->cost || !c->cost_ids || !c->see_through || !c->reflection ||
        !c->shadow) {
        fprintf(stderr, "vis-viewer: out of memory for the pass buffers\n");
        vv_cull_close(c);
        return VV_EXIT_FAILURE;
    }
    vw_error verr;
    memset(&verr, 0, sizeof verr);
    if (world_scene_create(ctx, world, NULL, &c->ws, NULL, &verr) != 0) {
        fprintf(stderr, "vis-viewer: building the scene: %s\n", verr.message);
        vv_cull_close(c);
        return VV_EXIT_FAILURE;
    }
    if (vis_zcull_create(ctx, &c->zcull) != VIS_OK) {
        fprintf(stderr, "vis-viewer: vis_zcull_create: %s\n", vis_context_last_error(ctx));
        vv_cull_close(c);
        return VV_EXIT_FAILURE;
    }
    if (vv_cull_grow(c) != 0 || vv_cull_set_resolution(c, width, height) != 0) {
        vv_cull_close(c);
        return VV_EXIT_FAILURE;
    }
    return VV_EXIT_OK;
}

void vv_cull_close(vv_cull *c)
{
    /* The scene first: a context that traced it holds a copy (vis_context_destroy). */
    vis_zcull_destroy(c->zcull);
    world_scene_destroy(c->ws);
    for (int i = 0; i < 2; ++i)
        if (c->ctx[i] && i != c->owner)
            vis_context_destroy(c->ctx[i]);
    vis_context_destroy(c->ctx[c->owner]);
    free(c->ids);
    free(c->depth);
    free(c->zdepth);
    free(c->cost);
    free(c->cost_ids);
    free(c->see_through);
    free(c->reflection);
    free(c->shadow);
    free(c->entries);
    free(c->fx_entries);
    memset(c, 0, sizeof *c);
}

int vv_cull_grow(vv_cull *c)
{
    size_t need = vis_drawlist_bound(world_scene_scene(c->ws));
    if (need < 1)
        need = 1;
    if (need <= c->capacity)
        return 0;
    vis_draw_entry *e = realloc(c->entries, need * sizeof *e);
    if (e)
        c->entries = e;
    vis_effect_entry *fe = e ? realloc(c->fx_entries, need * sizeof *fe) : NULL;
    if (!fe) {
        fprintf(stderr, "vis-viewer: out of memory for a draw list of %zu entries\n", need);
        return -1;
    }
    c->fx_entries = fe;
    c->capacity = need;
    return 0;
}

int vv_cull_toggle_backend(vv_cull *c)
{
    int other = 1 - c->active;
    if (!c->ctx[other]) {
        vis_backend_kind kind = other ? VIS_BACKEND_OPENCL : VIS_BACKEND_CPU;
        if (open_context(kind, &c->ctx[other], &c->info[other], c->opencl_error, sizeof c->opencl_error) != 0) {
            c->opencl_failed = 1;
            return -1;
        }
    }
    c->active = other;
    return 0;
}

int vv_cull_set_resolution(vv_cull *c, uint32_t width, uint32_t height)
{
    if (width < 1 || height < 1 || width > VV_MAX_PASS || height > VV_MAX_PASS) {
        fprintf(stderr, "vis-viewer: pass resolution %ux%u is outside 1..%u per axis\n", width, height, VV_MAX_PASS);
        return -1;
    }
    c->width = width;
    c->height = height;
    c->ids_valid = c->zdepth_valid = c->cost_valid = 0;
    return 0;
}

const vis_backend_info *vv_cull_backend(const vv_cull *c) { return &c->info[c->active]; }

static int fail_vis(const vis_context *ctx, const char *what)
{
    fprintf(stderr, "vis-viewer: %s: %s\n", what, vis_context_last_error(ctx));
    return VV_EXIT_FAILURE;
}

const char *vv_cull_effects_ignored_by(const vv_cull *c)
{
    switch (c->method) {
    case VV_METHOD_RAY_OBJECT: return NULL;
    case VV_METHOD_RAY_LEAF: return "leaf IDs (effects buffers hold object IDs)";
    case VV_METHOD_ZBUF: return "the z-buffer culler does not trace them";
    default: return "no culling draws every object";
    }
}

/* The ray pass with effects and its draw list with reasons, as `vis cull --effects` makes
 * them (the buffers of the effects that are off are not handed over, so they add no
 * reason). entries[] gets the IDs and direct pixels, for what draws and boxes by entries. */
static int effects_pass(vv_cull *c, vis_context *ctx, vis_scene *scene, const vis_trace_desc *plain)
{
    size_t n = (size_t)c->width * c->height;
    vis_trace_desc td = *plain;
    td.effects = c->fx.bits;
    td.see_through_layers = VC_SEE_THROUGH_LAYERS;
    memcpy(td.light_dir, c->fx.light, sizeof td.light_dir);
    td.fog_dist = c->fx.fog;
    uint32_t bits = c->fx.bits;
    vis_effect_buffers b;
    memset(&b, 0, sizeof b);
    b.ids = c->ids, b.ids_capacity = n;
    b.depth = c->depth, b.depth_capacity = n;
    if (bits & VIS_EFFECT_SEE_THROUGH)
        b.see_through = c->see_through, b.see_through_capacity = n * VC_SEE_THROUGH_LAYERS;
    if (bits & VIS_EFFECT_REFLECT)
        b.reflection = c->reflection, b.reflection_capacity = n;
    if (bits & VIS_EFFECT_SHADOWS)
        b.shadow = c->shadow, b.shadow_capacity = n;
    if (vis_trace_effects(ctx, scene, &c->camera, &td, &b) != VIS_OK)
        return fail_vis(ctx, "vis_trace_effects");
    vis_timing tm;
    if (vis_context_last_timing(ctx, &tm) == VIS_OK)
        c->pass_ms = tm.kernel_ms;
    if (vis_drawlist_build_effects(ctx, scene, &b, c->width, c->height, VC_SEE_THROUGH_LAYERS, c->fx_entries,
                                   c->capacity, &c->count) != VIS_OK)
        return fail_vis(ctx, "vis_drawlist_build_effects");
    memset(c->fx_objects, 0, sizeof c->fx_objects);
    memset(c->fx_only, 0, sizeof c->fx_only);
    for (size_t i = 0; i < c->count; ++i) {
        const vis_effect_entry *e = &c->fx_entries[i];
        c->entries[i].id = e->id;
        c->entries[i].pixels = e->pixels[0];
        for (int k = 0; k < VIS_REASON_COUNT; ++k) {
            uint32_t has = (e->reasons >> k) & 1u;
            c->fx_objects[k] += has;
            c->fx_only[k] += has && !(e->reasons & VIS_REASON_DIRECT);
        }
    }
    c->fx_state = VV_FX_RAN;
    c->fx_traced = bits;
    return VV_EXIT_OK;
}

int vv_cull_run(vv_cull *c, const vv_view *view)
{
    vis_context *ctx = c->ctx[c->active];
    vis_scene *scene = world_scene_scene(c->ws);
    double t0 = vc_now_ms();
    vv_look_at(view, &c->view);
    vv_perspective(view->fovy_deg, (double)c->width / (double)c->height, VV_NEAR, VV_FAR, &c->proj);
    /* The engine's path: libvis gets the matrices, not the eye and target. */
    if (vis_camera_from_matrices(ctx, c->view.m, c->proj.m, c->width, c->height, &c->camera) != VIS_OK)
        return fail_vis(ctx, "vis_camera_from_matrices");
    size_t n = (size_t)c->width * c->height;
    c->pass_ms = 0.0;
    c->ids_valid = c->zdepth_valid = c->cost_valid = 0;
    c->fx_state = c->fx.bits ? VV_FX_IGNORED : VV_FX_OFF;
    switch (c->method) {
    case VV_METHOD_RAY_OBJECT:
    case VV_METHOD_RAY_LEAF: {
        vis_trace_desc td;
        vis_trace_desc_defaults(&td);
        td.width = c->width;
        td.height = c->height;
        td.ids = c->method == VV_METHOD_RAY_LEAF ? VIS_IDS_LEAF : VIS_IDS_OBJECT;
        int rc;
        if (c->fx.bits && c->method == VV_METHOD_RAY_OBJECT) {
            if ((rc = effects_pass(c, ctx, scene, &td)) != VV_EXIT_OK)
                return rc;
        } else {
            if (vis_trace(ctx, scene, &c->camera, &td, c->ids, n, c->depth, n) != VIS_OK)
                return fail_vis(ctx, "vis_trace");
            vis_timing tm;
            if (vis_context_last_timing(ctx, &tm) == VIS_OK)
                c->pass_ms = tm.kernel_ms;
            if (vis_drawlist_build(ctx, scene, c->ids, c->width, c->height, td.ids, c->entries, c->capacity,
                                   &c->count) != VIS_OK)
                return fail_vis(ctx, "vis_drawlist_build");
        }
        c->ids_valid = 1;
        /* The heat map: the same pass again without effects, counting (CPU packets only;
         * elsewhere the overlay says so). Not timed into cull_ms's pass figure. */
        c->cost_valid = c->want_cost && vis_trace_cost(ctx, scene, &c->camera, &td, c->cost_ids, n, c->cost, n) == VIS_OK;
        break;
    }
    case VV_METHOD_ZBUF: {
        vis_zcull_desc zd;
        vis_zcull_desc_defaults(&zd);
        zd.width = c->width;
        zd.height = c->height;
        vis_zcull_stats zs;
        vis_context *owner = c->ctx[c->owner];
        /* The culler runs on the scene's own context whatever backend traces. */
        if (vis_zcull_run(c->zcull, scene, &c->camera, &zd, c->entries, c->capacity, &c->count, &zs) != VIS_OK)
            return fail_vis(owner, "vis_zcull_run");
        c->pass_ms = zs.ms_total;
        if (vis_zcull_depth(c->zcull, c->zdepth, n) != VIS_OK)
            return fail_vis(owner, "vis_zcull_depth");
        c->zdepth_valid = 1;
        break;
    }
    default:
        c->count = 0; /* main.c draws every object */
        break;
    }
    c->cull_ms = vc_now_ms() - t0;
    return VV_EXIT_OK;
}
