/* main.c — vis-viewer: set-up, the frame loop (interactive or scripted), tear-down.
 *
 * A frame: input -> camera -> culling (libvis gets the view and projection matrices) -> the
 * draw list's objects drawn -> overlays, HUD -> in the scripted mode a GL error check, and on
 * the last frame the screenshot and the draw list. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera_path.h"
#include "cull.h"
#include "edit.h"
#include "gl_util.h"
#include "hud.h"
#include "list_file.h"
#include "meshes.h"
#include "options.h"
#include "out_file.h"
#include "overlays.h"
#include "screenshot.h"
#include "timer.h"
#include "window.h"

typedef struct vv_app {
    vv_options opt;
    vw_world *world;
    double origin[3], extent;
    vv_window win;
    vv_cull cull;
    vv_meshes *meshes;
    vv_hud *hud;
    vv_overlays *ovl;
    vv_view view;                 /* where the 3D view looks from                         */
    vc_view path[VC_MAX_VIEWS];
    size_t path_count;
    int frozen;                   /* culling frozen: the draw list and camera are kept      */
    int orbit;
    double speed;                 /* world units per second                               */
    vv_tool tool;
    int radius;
    uint8_t material;
    int have_edit;
    vv_edit_result last_edit;
    int help;
    double frame_ms, draw_ms, last_frame_t;
    uint64_t tris_drawn;
    char message[300];            /* a one-line notice on the HUD (screenshot written, ...) */
} vv_app;

/* The 3D view's rectangle in the framebuffer: the pass's aspect, as tall as the window. */
static void main_rect(const vv_app *a, int *x, int *y, int *w, int *h)
{
    int fh = a->win.fb_h, fw = a->win.fb_w;
    int vw = (int)lround((double)fh * a->cull.width / a->cull.height);
    int vh = fh;
    if (vw > fw) {
        vw = fw;
        vh = (int)lround((double)fw * a->cull.height / a->cull.width);
    }
    *x = 0, *y = 0, *w = vw, *h = vh;
}

static void view_mvp(const vv_app *a, float out[16])
{
    vv_view local;
    vv_view_local(&a->view, a->origin, &local);
    vv_mat4 v, p, mvp;
    vv_look_at(&local, &v);
    vv_perspective(a->view.fovy_deg, (double)a->cull.width / a->cull.height, VV_NEAR, VV_FAR, &p);
    vv_mat4_mul(&p, &v, &mvp);
    vv_gl_matrix(mvp.m, out);
}

/* The frozen camera's frustum (scene-local), out to the far side of the world. */
static void frustum_lines(vv_app *a)
{
    const vv_mat4 *v = &a->cull.view;
    double r[3], u[3], f[3], e[3];
    for (int c = 0; c < 3; ++c) {
        r[c] = v->m[c * 4 + 0];
        u[c] = v->m[c * 4 + 1];
        f[c] = -v->m[c * 4 + 2];
        e[c] = a->cull.camera.eye[c] - a->origin[c];
    }
    double th = tan(a->cull.camera.fovy_deg * 0.5 * (3.14159265358979323846 / 180.0));
    double asp = (double)a->cull.width / a->cull.height;
    const double dist[2] = {1.0, a->extent};
    float corner[2][4][3];
    for (int d = 0; d < 2; ++d)
        for (int k = 0; k < 4; ++k) {
            double sx = (k == 1 || k == 2) ? 1.0 : -1.0, sy = k >= 2 ? 1.0 : -1.0;
            for (int c = 0; c < 3; ++c)
                corner[d][k][c] = (float)(e[c] + dist[d] * (f[c] + sx * th * asp * r[c] + sy * th * u[c]));
        }
    const uint32_t yellow = 0xFF00FFFFu;
    float eye[3] = {(float)e[0], (float)e[1], (float)e[2]};
    for (int k = 0; k < 4; ++k) {
        vv_lines_add(a->ovl, eye, corner[1][k], yellow);
        vv_lines_add(a->ovl, corner[0][k], corner[0][(k + 1) % 4], yellow);
        vv_lines_add(a->ovl, corner[1][k], corner[1][(k + 1) % 4], yellow);
    }
}

/* The boxes of the objects the draw list leaves out (the list is sorted by ID). */
static void culled_boxes(vv_app *a)
{
    const vis_draw_entry *e = a->cull.entries;
    size_t n = a->cull.count, i = 0;
    uint32_t max = vv_meshes_max_id(a->meshes);
    for (uint32_t id = 1; id <= max; ++id) {
        while (i < n && e[i].id < id)
            ++i;
        if (i < n && e[i].id == id)
            continue;
        float lo[3], hi[3];
        if (vv_meshes_box(a->meshes, id, lo, hi))
            vv_lines_box(a->ovl, lo, hi, 0xFF3030FFu);
    }
}

/* The effects lines: which are on (and the light and fog), then either why the method
 * ignores them or the pass's time and its entries per reason, the tinted ones in their tint. */
static int effects_hud(vv_app *a, int x, int y)
{
    const float grey[3] = {0.75f, 0.75f, 0.75f}, yellow[3] = {1, 0.9f, 0.3f}, white[3] = {1, 1, 1};
    const vv_cull *c = &a->cull;
    if (!c->fx.bits)
        return vv_hud_line(a->hud, x, y, grey, "effects off (keys 1-4)");
    char names[64], params[96] = "";
    vc_effects_format(c->fx.bits, names, sizeof names);
    if (c->fx.bits & VIS_EFFECT_SHADOWS)
        snprintf(params, sizeof params, "  light (%g, %g, %g)", c->fx.light[0], c->fx.light[1], c->fx.light[2]);
    if (c->fx.bits & VIS_EFFECT_FOG) {
        size_t at = strlen(params);
        snprintf(params + at, sizeof params - at, "  fog %g", c->fx.fog);
    }
    y = vv_hud_line(a->hud, x, y, white, "effects %s%s", names, params);
    const char *by = vv_cull_effects_ignored_by(c);
    if (c->fx_state != VV_FX_RAN && by)
        return vv_hud_line(a->hud, x, y, yellow, "effects ignored: %s", by);
    if (c->fx_state != VV_FX_RAN) /* turned on while culling is frozen */
        return vv_hud_line(a->hud, x, y, yellow, "effects not in the frozen list (F culls again)");
    const uint32_t *o = c->fx_objects, *only = c->fx_only;
    y = vv_hud_line(a->hud, x, y, white, "effects pass %.2f ms: direct %u  seen through %u  reflected %u  casters %u",
                    a->frozen ? 0.0 : c->pass_ms, o[0], o[1], o[2], o[3]);
    static const char *const what[3] = {"only seen through", "only in reflections", "only casting shadows"};
    static const uint32_t reason[3] = {VIS_REASON_SEE_THROUGH, VIS_REASON_REFLECTION, VIS_REASON_SHADOW};
    int xx = x;
    for (int k = 0; k < 3; ++k) {
        float rgb[3];
        vv_tint_of(reason[k], rgb);
        xx = vv_hud_span(a->hud, xx, y, rgb, "%s %u  ", what[k], only[k + 1]);
    }
    return vv_hud_line(a->hud, xx, y, grey, "(tinted)");
}

static void draw_hud(vv_app *a, int vx, int vw)
{
    const float white[3] = {1, 1, 1}, yellow[3] = {1, 0.9f, 0.3f}, grey[3] = {0.75f, 0.75f, 0.75f};
    vv_hud_begin(a->hud, a->win.fb_w, a->win.fb_h, 2);
    const vis_backend_info *b = vv_cull_backend(&a->cull);
    int all = a->cull.method == VV_METHOD_NONE;
    uint32_t objects = vv_meshes_objects(a->meshes);
    size_t visible = all ? objects : a->cull.count;
    int y = 8, x = vx + 8;
    y = vv_hud_line(a->hud, x, y, white, "%s", a->opt.scene);
    y = vv_hud_line(a->hud, x, y, white, "%s | %s (%s) | pass %ux%u | ids %s", vv_method_name(a->cull.method),
                    b->name, b->device, a->cull.width, a->cull.height,
                    a->cull.method == VV_METHOD_RAY_LEAF ? "leaf" : a->cull.method == VV_METHOD_RAY_OBJECT ? "object" : "-");
    y = vv_hud_line(a->hud, x, y, white, "visible %zu / %u objects   triangles %llu / %llu", visible, objects,
                    (unsigned long long)a->tris_drawn, (unsigned long long)vv_meshes_total_triangles(a->meshes));
    y = vv_hud_line(a->hud, x, y, white, "cull %.2f ms (pass %.2f)  draw %.2f ms  frame %.1f ms",
                    a->frozen ? 0.0 : a->cull.cull_ms, a->frozen ? 0.0 : a->cull.pass_ms, a->draw_ms, a->frame_ms);
    if (a->frozen)
        y = vv_hud_line(a->hud, x, y, yellow, "culling FROZEN (F): frustum in yellow%s", a->opt.boxes ? ", culled boxes in red" : "");
    y = effects_hud(a, x, y);
    y = vv_hud_line(a->hud, x, y, grey, "tool %s r%d material %u%s", vv_tool_name(a->tool), a->radius, a->material,
                    a->orbit ? "  orbit" : "  fly");
    if (a->have_edit) {
        const vv_edit_result *e = &a->last_edit;
        y = vv_hud_line(a->hud, x, y, yellow, "edit %.2f ms: %llu voxels, %u chunks (mesh %.2f, leaf %.2f, pick %.2f)",
                        e->total_ms, (unsigned long long)e->changed, e->chunks, e->remesh_ms, e->scene_ms, e->pick_ms);
    }
    if (a->message[0])
        y = vv_hud_line(a->hud, x, y, yellow, "%s", a->message);
    if (a->help) {
        int hy = a->win.fb_h - 5 * 20 - 4;
        hy = vv_hud_line(a->hud, x, hy, grey, "WASD QE move, right-drag look, wheel speed, Tab orbit (left-drag)");
        hy = vv_hud_line(a->hud, x, hy, grey, "M method  B backend  P pass res  F freeze  C boxes  O overlay");
        hy = vv_hud_line(a->hud, x, hy, grey, "click edit  T tool  [ ] brush  , . material  F12 screenshot");
        hy = vv_hud_line(a->hud, x, hy, grey, "effects: 1 see-through  2 reflect  3 shadows  4 fog");
        vv_hud_line(a->hud, x, hy, grey, "H help  Esc quit");
    }
    (void)vw;
    vv_hud_end(a->hud);
}

/* The last frame's list as `vis cull --dump-list` writes it (list_file.h): with reasons after
 * an effects pass, "ID PIXELS" after a plain one, every object with 0 pixels without
 * culling. */
static int write_drawlist(const vv_app *a, const char *path)
{
    char err[1024];
    int bad = 0;
    if (a->cull.method != VV_METHOD_NONE) {
        bad = a->cull.fx_state == VV_FX_RAN
                  ? vc_effect_list_write(path, a->cull.fx_entries, a->cull.count, err, sizeof err)
                  : vc_list_write(path, a->cull.entries, a->cull.count, err, sizeof err);
        if (bad)
            fprintf(stderr, "vis-viewer: %s\n", err);
        return bad ? VV_EXIT_FAILURE : VV_EXIT_OK;
    }
    vc_out_file f;
    if (vc_out_open(&f, path, err, sizeof err) != 0) {
        fprintf(stderr, "vis-viewer: %s\n", err);
        return VV_EXIT_FAILURE;
    }
    uint32_t max = vv_meshes_max_id(a->meshes);
    float lo[3], hi[3];
    for (uint32_t id = 1; id <= max && !f.error; ++id)
        if (vv_meshes_box(a->meshes, id, lo, hi))
            vc_out_printf(&f, "%u 0\n", id);
    if (vc_out_close(&f, 1, err, sizeof err) != 0) {
        fprintf(stderr, "vis-viewer: %s\n", err);
        return VV_EXIT_FAILURE;
    }
    return VV_EXIT_OK;
}

static int do_edit(vv_app *a, double px, double py)
{
    if (vv_edit_at(&a->cull, px, py, a->tool, a->radius, a->material, &a->last_edit) != VV_EXIT_OK)
        return VV_EXIT_FAILURE;
    a->have_edit = 1;
    const vv_edit_result *e = &a->last_edit;
    if (e->hit)
        printf("edit %s r%d at voxel %lld,%lld,%lld (object %u) material %u: %llu voxels changed, %u chunks "
               "re-meshed, %.3f ms (pick %.3f, mesh %.3f, leaf update %.3f)\n",
               vv_tool_name(a->tool), a->radius, (long long)e->voxel[0], (long long)e->voxel[1],
               (long long)e->voxel[2], e->object, a->material, (unsigned long long)e->changed, e->chunks,
               e->total_ms, e->pick_ms, e->remesh_ms, e->scene_ms);
    else
        printf("edit %s at pixel %.1f,%.1f: the ray hits nothing\n", vv_tool_name(a->tool), px, py);
    fflush(stdout);
    return VV_EXIT_OK;
}

static void handle_keys(vv_app *a, double dt)
{
    vv_input *in = &a->win.in;
    if (in->pressed[GLFW_KEY_ESCAPE])
        glfwSetWindowShouldClose(a->win.win, 1);
    if (in->pressed[GLFW_KEY_M]) {
        a->cull.method = (vv_method)((a->cull.method + 1) % VV_METHOD_COUNT);
    }
    if (in->pressed[GLFW_KEY_B]) {
        if (vv_cull_toggle_backend(&a->cull) != 0)
            snprintf(a->message, sizeof a->message, "backend: %s", a->cull.opencl_error);
        else
            a->message[0] = '\0';
    }
    if (in->pressed[GLFW_KEY_P]) {
        uint32_t s = a->cull.width >= 1024 ? 128 : a->cull.width < 128 ? 128 : a->cull.width * 2;
        vv_cull_set_resolution(&a->cull, s, s);
    }
    if (in->pressed[GLFW_KEY_F])
        a->frozen = !a->frozen;
    if (in->pressed[GLFW_KEY_C])
        a->opt.boxes = !a->opt.boxes;
    if (in->pressed[GLFW_KEY_O])
        a->opt.overlay = (vv_overlay)((a->opt.overlay + 1) % VV_OVERLAY_COUNT);
    if (in->pressed[GLFW_KEY_H])
        a->help = !a->help;
    static const uint32_t fx_keys[4] = {VIS_EFFECT_SEE_THROUGH, VIS_EFFECT_REFLECT, VIS_EFFECT_SHADOWS, VIS_EFFECT_FOG};
    for (int k = 0; k < 4; ++k)
        if (in->pressed[GLFW_KEY_1 + k])
            a->cull.fx.bits ^= fx_keys[k];
    if (in->pressed[GLFW_KEY_TAB])
        a->orbit = !a->orbit;
    if (in->pressed[GLFW_KEY_T])
        a->tool = (vv_tool)((a->tool + 1) % VV_TOOL_COUNT);
    if (in->pressed[GLFW_KEY_LEFT_BRACKET] && a->radius > 0)
        a->radius--;
    if (in->pressed[GLFW_KEY_RIGHT_BRACKET] && a->radius < 16)
        a->radius++;
    if (in->pressed[GLFW_KEY_COMMA] && a->material > 1)
        a->material--;
    if (in->pressed[GLFW_KEY_PERIOD] && a->material < 255)
        a->material++;
    if (in->wheel != 0.0)
        a->speed *= pow(1.25, in->wheel);
    double step = a->speed * dt, fw = 0, rt = 0, up = 0;
    if (vv_window_key_down(&a->win, GLFW_KEY_W))
        fw += step;
    if (vv_window_key_down(&a->win, GLFW_KEY_S))
        fw -= step;
    if (vv_window_key_down(&a->win, GLFW_KEY_D))
        rt += step;
    if (vv_window_key_down(&a->win, GLFW_KEY_A))
        rt -= step;
    if (vv_window_key_down(&a->win, GLFW_KEY_E))
        up += step;
    if (vv_window_key_down(&a->win, GLFW_KEY_Q))
        up -= step;
    if (fw != 0 || rt != 0 || up != 0)
        vv_fly_move(&a->view, fw, rt, up);
    if (in->dx != 0 || in->dy != 0)
        vv_fly_turn(&a->view, in->dx * 0.004, -in->dy * 0.004);
    if (a->orbit && (in->odx != 0 || in->ody != 0))
        vv_orbit(&a->view, in->odx * 0.006, in->ody * 0.006, 1.0);
}

/* Renders one frame; in the scripted mode `last` writes the screenshot and draw list. */
static int frame(vv_app *a, uint32_t index, int scripted, int last)
{
    int rc = VV_EXIT_OK;
    a->cull.want_cost = a->opt.overlay == VV_OVERLAY_COST;
    if (scripted) {
        if (!a->opt.have_camera && a->path_count) {
            const vis_camera *pc = &a->path[index % a->path_count].camera;
            memcpy(a->view.eye, pc->eye, sizeof pc->eye);
            memcpy(a->view.target, pc->target, sizeof pc->target);
            a->view.fovy_deg = pc->fovy_deg > 0 ? pc->fovy_deg : 60.0;
        }
        if (index == 0 && a->opt.have_cull_camera) {
            if ((rc = vv_cull_run(&a->cull, &a->opt.cull_camera)) != VV_EXIT_OK)
                return rc;
            a->frozen = 1;
        }
        if (a->opt.have_edit && index == (a->opt.frames > 1 ? 1u : 0u)) {
            /* The edit's ray comes from the current camera's pass, as a click would. */
            if (!a->frozen && (rc = vv_cull_run(&a->cull, &a->view)) != VV_EXIT_OK)
                return rc;
            a->tool = a->opt.edit_tool;
            a->radius = a->opt.edit_radius;
            if ((rc = do_edit(a, a->opt.edit_px + 0.5, a->opt.edit_py + 0.5)) != VV_EXIT_OK)
                return rc;
            /* A frozen list is culled again so that it holds the edit, as the freeze's
             * camera would see it now. */
            if (a->frozen && a->opt.have_cull_camera && (rc = vv_cull_run(&a->cull, &a->opt.cull_camera)) != VV_EXIT_OK)
                return rc;
        }
    }
    if (!a->frozen && (rc = vv_cull_run(&a->cull, &a->view)) != VV_EXIT_OK)
        return rc;
    if (scripted && index == 0 && a->opt.freeze)
        a->frozen = 1;

    int vx, vy, vw, vh;
    main_rect(a, &vx, &vy, &vw, &vh);
    glViewport(0, 0, a->win.fb_w, a->win.fb_h);
    glDisable(GL_SCISSOR_TEST);
    glClearColor(0.12f, 0.12f, 0.14f, 1.0f); /* the panel beside the 3D view */
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glViewport(vx, a->win.fb_h - vy - vh, vw, vh);
    glEnable(GL_SCISSOR_TEST);
    glScissor(vx, a->win.fb_h - vy - vh, vw, vh);
    glClearColor(135 / 255.0f, 179 / 255.0f, 230 / 255.0f, 1.0f); /* sky */
    glClear(GL_COLOR_BUFFER_BIT);
    glDisable(GL_SCISSOR_TEST);
    glEnable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    float mvp[16];
    view_mvp(a, mvp);
    double t0 = vc_now_ms();
    int fx = a->cull.fx_state == VV_FX_RAN;
    const vv_draw_desc dd = {a->cull.entries, a->cull.count, a->cull.method == VV_METHOD_NONE,
                             fx ? a->cull.fx_entries : NULL, fx && (a->cull.fx_traced & VIS_EFFECT_SEE_THROUGH)};
    a->tris_drawn = vv_meshes_draw(a->meshes, &dd, mvp);
    glFinish(); /* so that draw ms is the GPU's (llvmpipe's) time, not the call's */
    a->draw_ms = vc_now_ms() - t0;
    vv_lines_begin(a->ovl);
    if (a->frozen)
        frustum_lines(a);
    if (a->opt.boxes && a->cull.method != VV_METHOD_NONE)
        culled_boxes(a);
    vv_lines_end(a->ovl, mvp);
    glViewport(0, 0, a->win.fb_w, a->win.fb_h);
    int px = vw, pw = a->win.fb_w - vw;
    if (pw >= 32) {
        int ih = (int)lround((double)pw * a->cull.height / a->cull.width);
        if (a->opt.overlay == VV_OVERLAY_IDS && a->cull.ids_valid)
            vv_overlay_ids(a->ovl, a->cull.ids, a->cull.width, a->cull.height, px, 0, pw, ih, a->win.fb_w, a->win.fb_h);
        else if (a->opt.overlay == VV_OVERLAY_DEPTH && a->cull.zdepth_valid)
            vv_overlay_depth(a->ovl, a->cull.zdepth, a->cull.width, a->cull.height, (float)a->extent, px, 0, pw, ih,
                             a->win.fb_w, a->win.fb_h);
        else if (a->opt.overlay == VV_OVERLAY_COST && a->cull.cost_valid)
            vv_overlay_cost(a->ovl, a->cull.cost, a->cull.width, a->cull.height, px, 0, pw, ih, a->win.fb_w,
                            a->win.fb_h);
    }
    if (a->opt.hud)
        draw_hud(a, vx, vw);
    if (vv_gl_errors("drawing a frame") != 0 && scripted)
        return VV_EXIT_FAILURE;
    if (a->win.in.pressed[GLFW_KEY_F12] || (scripted && last && a->opt.screenshot)) {
        char name[64], err[1024];
        const char *path = a->opt.screenshot;
        if (!scripted || !path) {
            snprintf(name, sizeof name, "vis-viewer-%u.png", index);
            path = name;
        }
        if (vv_screenshot(path, a->win.fb_w, a->win.fb_h, err, sizeof err) != 0) {
            fprintf(stderr, "vis-viewer: screenshot: %s\n", err);
            if (scripted)
                return VV_EXIT_FAILURE;
        } else {
            snprintf(a->message, sizeof a->message, "screenshot %s", path);
            printf("screenshot %s: %dx%d, 3D view at %d,%d %dx%d\n", path, a->win.fb_w, a->win.fb_h, vx, vy, vw, vh);
            fflush(stdout);
        }
    }
    if (scripted && last && a->opt.drawlist && (rc = write_drawlist(a, a->opt.drawlist)) != VV_EXIT_OK)
        return rc;
    glfwSwapBuffers(a->win.win);
    if (vv_gl_errors("swapping buffers") != 0 && scripted)
        return VV_EXIT_FAILURE;
    return VV_EXIT_OK;
}

static int run(vv_app *a)
{
    int scripted = a->opt.frames > 0;
    double stats_cull = 0, stats_draw = 0, stats_frame = 0;
    uint32_t n = 0;
    a->last_frame_t = vc_now_ms();
    for (uint32_t i = 0; !scripted || i < a->opt.frames; ++i) {
        if (!vv_window_poll(&a->win) && !scripted)
            break;
        double now = vc_now_ms();
        double dt = (now - a->last_frame_t) / 1000.0;
        a->frame_ms = now - a->last_frame_t;
        a->last_frame_t = now;
        if (scripted && a->opt.keys && i >= 1 && i - 1 < strlen(a->opt.keys)) {
            /* GLFW's key codes of letters, digits and [ ] , . are their (capital) ASCII codes. */
            char k = a->opt.keys[i - 1];
            a->win.in.pressed[(unsigned char)(k >= 'a' && k <= 'z' ? k - 'a' + 'A' : k)] = 1;
            handle_keys(a, 0.0);
        }
        if (!scripted) {
            handle_keys(a, dt > 0.25 ? 0.25 : dt);
            if (a->win.in.clicked) {
                int vx, vy, vw, vh;
                main_rect(a, &vx, &vy, &vw, &vh);
                double cx = a->win.in.click_x - vx, cy = a->win.in.click_y - vy;
                if (cx >= 0 && cy >= 0 && cx < vw && cy < vh && !a->frozen &&
                    do_edit(a, cx * a->cull.width / vw, cy * a->cull.height / vh) != VV_EXIT_OK)
                    return VV_EXIT_FAILURE;
            }
        }
        int rc = frame(a, i, scripted, scripted && i + 1 == a->opt.frames);
        if (rc != VV_EXIT_OK)
            return rc;
        if (i > 0) { /* the first frame warms the backend's copy of the scene */
            stats_cull += a->frozen ? 0.0 : a->cull.cull_ms;
            stats_draw += a->draw_ms;
            stats_frame += vc_now_ms() - now;
            ++n;
        }
    }
    if (scripted) {
        const vis_backend_info *b = vv_cull_backend(&a->cull);
        printf("frames %u: %s, %s (%s), pass %ux%u; mean over frames 2..%u: cull %.2f ms, draw %.2f ms, frame "
               "%.2f ms; visible %zu of %u objects\n",
               a->opt.frames, vv_method_name(a->cull.method), b->name, b->device, a->cull.width, a->cull.height,
               a->opt.frames, n ? stats_cull / n : 0.0, n ? stats_draw / n : 0.0, n ? stats_frame / n : 0.0,
               a->cull.method == VV_METHOD_NONE ? (size_t)vv_meshes_objects(a->meshes) : a->cull.count,
               vv_meshes_objects(a->meshes));
        printf("GL: %s | %s\n", (const char *)glGetString(GL_RENDERER), (const char *)glGetString(GL_VERSION));
    }
    return VV_EXIT_OK;
}

static int load_world(vv_app *a)
{
    vw_error err;
    memset(&err, 0, sizeof err);
    fprintf(stderr, "vis-viewer: loading %s ...\n", a->opt.scene);
    vw_status st = vw_world_from_spec(a->opt.scene, NULL, NULL, NULL, &a->world, &err);
    if (st != VW_OK) {
        fprintf(stderr, "vis-viewer: %s: %s\n", a->opt.scene, err.message[0] ? err.message : vw_status_string(st));
        return st == VW_ERROR_INVALID_ARGUMENT ? VV_EXIT_USAGE : VV_EXIT_FAILURE;
    }
    double lo[3], hi[3];
    world_scene_bounds(a->world, lo, hi);
    memcpy(a->origin, lo, sizeof lo);
    a->extent = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                     (hi[2] - lo[2]) * (hi[2] - lo[2]));
    a->path_count = vc_camera_path(a->world, a->path, VC_MAX_VIEWS);
    return VV_EXIT_OK;
}

int main(int argc, char **argv)
{
    vv_app *a = calloc(1, sizeof *a);
    if (!a) {
        fprintf(stderr, "vis-viewer: out of memory\n");
        return VV_EXIT_FAILURE;
    }
    int rc = vv_options_parse(argc, argv, &a->opt);
    if (rc != VV_EXIT_OK) {
        free(a);
        return rc < 0 ? VV_EXIT_OK : rc;
    }
    /* The window first: without a display there is nothing to wait for. */
    if (vv_window_open(&a->win, a->opt.win_w, a->opt.win_h, 1, "vis-viewer") != 0) {
        free(a);
        return VV_EXIT_FAILURE;
    }
    rc = load_world(a);
    if (rc == VV_EXIT_OK)
        rc = vv_cull_open(&a->cull, a->world, a->opt.backend, a->opt.width, a->opt.height);
    if (rc == VV_EXIT_OK) {
        a->cull.method = a->opt.method;
        a->cull.fx = a->opt.effects;
        a->meshes = vv_meshes_create(a->cull.ws);
        a->hud = vv_hud_create();
        a->ovl = vv_overlays_create();
        if (!a->meshes || !a->hud || !a->ovl || vv_gl_errors("set-up") != 0) {
            fprintf(stderr, "vis-viewer: GL set-up failed\n");
            rc = VV_EXIT_FAILURE;
        }
    }
    if (rc == VV_EXIT_OK) {
        world_scene_set_chunk_hook(a->cull.ws, vv_meshes_chunk_hook, a->meshes);
        if (a->opt.have_camera) {
            a->view = a->opt.camera;
        } else {
            vis_camera c;
            vc_camera_default(a->world, &c);
            memcpy(a->view.eye, c.eye, sizeof c.eye);
            memcpy(a->view.target, c.target, sizeof c.target);
            a->view.fovy_deg = c.fovy_deg > 0 ? c.fovy_deg : 60.0;
        }
        a->speed = a->extent / 20.0;
        a->radius = 0;
        a->material = a->opt.material;
        a->help = 1;
        rc = run(a);
    }
    if (a->cull.ws)
        world_scene_set_chunk_hook(a->cull.ws, NULL, NULL);
    vv_overlays_destroy(a->ovl);
    vv_hud_destroy(a->hud);
    vv_meshes_destroy(a->meshes);
    if (a->cull.ctx[0] || a->cull.ctx[1])
        vv_cull_close(&a->cull);
    vw_world_destroy(a->world);
    vv_window_close(&a->win);
    free(a);
    return rc;
}
