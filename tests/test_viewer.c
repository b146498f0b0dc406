/* test_viewer.c — vis-viewer (demo/) in a real window under Xvfb with Mesa's llvmpipe.
 *
 * Each run renders a few frames in the scripted mode and exits; the viewer itself fails
 * (exit 1) on any GL error after a frame (glGetError), so every run checks that too. The
 * screenshots are read back and checked: not blank, and most of the 3D view's non-sky pixels
 * are the colours of materials that the world really holds, with the viewer's documented
 * face shades (docs/viewer.md: 1.0 top, 0.5 bottom, 0.8 x, 0.65 z). The draw list the viewer
 * drew (--drawlist) must equal `vis cull --dump-list` for the same camera — also with culling
 * frozen at another camera than the one drawn from — and after a scripted edit it must equal
 * a draw list made here from scratch: the world loaded again, the same brush applied with
 * voxelworld, a new scene traced. With effects (--effects, keys 1-4) the list must equal `vis
 * cull --effects ... --dump-list`'s (reasons and pixels per reason), toggling every effect on
 * and off must end on the plain list, and the objects there for an effect alone must show in
 * their tint. A missing display must give a message and exit code 1.
 *
 * Skips (with the reason) when xvfb-run is not installed, or the .vox data is absent. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <png.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "run_tool.h"
#include "test_support.h"
#include "vis/vis.h"
#include "voxelworld/vw.h"
#include "world_scene.h"

#define VIEWER_EXE VIS_BINARY_DIR "/demo/vis-viewer"
#define VIS_EXE VIS_BINARY_DIR "/tools/vis"
#define VOX_FILE "vox/mmmm_scene_store8.vox"

static char tmp_dir[512];
static char xvfb_run[1024];

static const char *tmp_path(const char *name)
{
    static char buf[4][600];
    static int k;
    k = (k + 1) % 4;
    snprintf(buf[k], sizeof buf[k], "%s/%s", tmp_dir, name);
    return buf[k];
}

/* xvfb-run and Xvfb on PATH: 1, else 0 with the reason printed for skip(). */
static int have_xvfb(void)
{
    const char *path = getenv("PATH");
    char dirs[4096];
    snprintf(dirs, sizeof dirs, "%s", path ? path : "/usr/bin:/bin");
    int run = 0, server = 0;
    for (char *save = NULL, *d = strtok_r(dirs, ":", &save); d; d = strtok_r(NULL, ":", &save)) {
        char p[1024];
        snprintf(p, sizeof p, "%s/xvfb-run", d);
        if (!run && access(p, X_OK) == 0) {
            snprintf(xvfb_run, sizeof xvfb_run, "%s", p);
            run = 1;
        }
        snprintf(p, sizeof p, "%s/Xvfb", d);
        server |= access(p, X_OK) == 0;
    }
    if (!run || !server) {
        print_message("SKIP: %s is not installed (Debian package xvfb): the viewer needs an X server to run "
                      "headless\n", run ? "Xvfb" : "xvfb-run");
        return 0;
    }
    return 1;
}

/* Runs the viewer under xvfb-run with llvmpipe; args are shell text. */
static vt_run_result run_viewer(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static vt_run_result run_viewer(const char *fmt, ...)
{
    char args[1800];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(args, sizeof args, fmt, ap);
    va_end(ap);
    /* Under AddressSanitizer: Mesa unloads its GL driver (dlclose) when the display closes,
     * and what the driver still held through its own globals then looks leaked, with stacks
     * that cannot be symbolised. Preloading the driver keeps it mapped until exit, so those
     * allocations stay reachable; every allocation of the viewer, libvis and voxelworld is
     * still checked (no suppressions). */
    const char *env = "LIBGL_ALWAYS_SOFTWARE=1 GALLIUM_DRIVER=llvmpipe"
#if defined(VT_ASAN) && defined(VIS_MESA_SWRAST_DRI)
                      " LD_PRELOAD=" VIS_MESA_SWRAST_DRI " ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:verify_asan_link_order=0"
#endif
        ;
    return vt_run(xvfb_run, tmp_dir, env, "-a -s '-screen 0 1024x768x24' '%s' %s", VIEWER_EXE, args);
}

static void assert_same_file(const char *a, const char *b)
{
    char *x = vt_slurp(a), *y = vt_slurp(b);
    assert_non_null(x);
    assert_non_null(y);
    if (strcmp(x, y) != 0) {
        size_t la = 0, lb = 0;
        for (const char *p = x; *p; ++p)
            la += *p == '\n';
        for (const char *p = y; *p; ++p)
            lb += *p == '\n';
        fail_msg("%s (%zu entries) differs from %s (%zu entries)", a, la, b, lb);
    }
    assert_true(strlen(x) > 0);
    free(x), free(y);
}

typedef struct picture {
    uint32_t w, h;
    unsigned char *rgb;
} picture;

static picture read_png(const char *path)
{
    picture p = {0, 0, NULL};
    png_image img;
    memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&img, path))
        fail_msg("%s: %s", path, img.message);
    img.format = PNG_FORMAT_RGB;
    p.w = img.width, p.h = img.height;
    p.rgb = malloc(PNG_IMAGE_SIZE(img));
    assert_non_null(p.rgb);
    if (!png_image_finish_read(&img, NULL, p.rgb, 0, NULL))
        fail_msg("%s: %s", path, img.message);
    return p;
}

/* "3D view at X,Y WxH" from the viewer's screenshot line. */
static void view_rect(const char *out, int r[4])
{
    const char *s = strstr(out, "3D view at ");
    assert_non_null(s);
    assert_int_equal(sscanf(s, "3D view at %d,%d %dx%d", &r[0], &r[1], &r[2], &r[3]), 4);
}

/* The materials the world holds (by scanning every voxel), as RGB with each face shade. */
typedef struct palette {
    unsigned char rgb[256 * 4][3];
    int n;
    int materials;
} palette;

static void world_palette(const char *spec, palette *pal)
{
    vw_world *w = NULL;
    vw_error err;
    if (vw_world_from_spec(spec, NULL, NULL, NULL, &w, &err) != VW_OK)
        fail_msg("%s: %s", spec, err.message);
    vw_world_info wi;
    vw_world_get_info(w, &wi);
    int used[256] = {0};
    for (int64_t z = 0; z < wi.size[2]; ++z)
        for (int64_t y = 0; y < wi.size[1]; ++y)
            for (int64_t x = 0; x < wi.size[0]; ++x)
                used[vw_world_get(w, wi.origin[0] + x, wi.origin[1] + y, wi.origin[2] + z)] = 1;
    static const float shades[4] = {1.0f, 0.5f, 0.8f, 0.65f};
    pal->n = pal->materials = 0;
    for (int m = 1; m < 256; ++m) {
        if (!used[m])
            continue;
        uint32_t c = vw_world_material(w, (uint32_t)m)->rgba;
        pal->materials++;
        for (int s = 0; s < 4; ++s) {
            for (int k = 0; k < 3; ++k)
                pal->rgb[pal->n][k] = (unsigned char)lroundf((float)((c >> (8 * k)) & 0xFF) * shades[s]);
            pal->n++;
        }
    }
    vw_world_destroy(w);
}

/* The 3D view is not blank and at least `min_fraction` of its non-sky pixels are world
 * colours (within 2 per channel: GL's conversion to 8 bits). */
static void check_picture(const char *png_path, const char *out, const palette *pal, double min_fraction)
{
    picture p = read_png(png_path);
    int r[4];
    view_rect(out, r);
    assert_true(r[0] >= 0 && r[1] >= 0 && r[2] > 0 && r[3] > 0);
    assert_true((uint32_t)(r[0] + r[2]) <= p.w && (uint32_t)(r[1] + r[3]) <= p.h);
    const unsigned char sky[3] = {135, 179, 230};
    size_t sky_px = 0, world_px = 0, matched = 0;
    unsigned char first[3];
    memcpy(first, p.rgb + ((size_t)r[1] * p.w + (size_t)r[0]) * 3, 3);
    int uniform = 1;
    for (int y = r[1]; y < r[1] + r[3]; ++y)
        for (int x = r[0]; x < r[0] + r[2]; ++x) {
            const unsigned char *c = p.rgb + ((size_t)y * p.w + (size_t)x) * 3;
            if (memcmp(c, first, 3) != 0)
                uniform = 0;
            if (abs(c[0] - sky[0]) <= 1 && abs(c[1] - sky[1]) <= 1 && abs(c[2] - sky[2]) <= 1) {
                ++sky_px;
                continue;
            }
            ++world_px;
            for (int i = 0; i < pal->n; ++i)
                if (abs(c[0] - pal->rgb[i][0]) <= 2 && abs(c[1] - pal->rgb[i][1]) <= 2 &&
                    abs(c[2] - pal->rgb[i][2]) <= 2) {
                    ++matched;
                    break;
                }
        }
    size_t total = (size_t)r[2] * r[3];
    print_message("%s: %zu pixels, %zu sky, %zu world, %.1f %% of them world colours (%d materials)\n", png_path, total,
                  sky_px, world_px, world_px ? 100.0 * matched / world_px : 0.0, pal->materials);
    assert_false(uniform);
    assert_true(world_px >= total / 10); /* the world covers a tenth of the view at least */
    if (!((double)matched >= min_fraction * (double)world_px))
        fail_msg("%s: only %zu of %zu non-sky pixels are the world's colours", png_path, matched, world_px);
    free(p.rgb);
}

/* Counts pixels of one exact colour in the whole picture. */
static size_t count_colour(const char *png_path, unsigned char r, unsigned char g, unsigned char b)
{
    picture p = read_png(png_path);
    size_t n = 0;
    for (size_t i = 0; i < (size_t)p.w * p.h; ++i)
        n += p.rgb[3 * i] == r && p.rgb[3 * i + 1] == g && p.rgb[3 * i + 2] == b;
    free(p.rgb);
    return n;
}

static void vis_cull_list(const char *scene, const char *camera, const char *out_path)
{
    vt_run_result r = vt_run(VIS_EXE, tmp_dir, NULL, "cull --scene '%s' --camera %s --dump-list '%s'", scene, camera,
                             out_path);
    vt_assert_exit(r, 0);
    vt_run_free(&r);
}

#define CAM_DEFAULT "100,120,-60,256,40,256"

static void test_no_display(void **state)
{
    (void)state;
    vt_run_result r = vt_run(VIEWER_EXE, tmp_dir, "env -u DISPLAY -u WAYLAND_DISPLAY", "--frames 1 --screenshot '%s'",
                             tmp_path("never.png"));
    vt_assert_exit(r, 1);
    assert_non_null(strstr(r.err, "no display"));
    assert_true(access(tmp_path("never.png"), F_OK) != 0);
    vt_run_free(&r);
    /* A display that does not exist: GLFW's own message, exit 1, no crash. */
    r = vt_run(VIEWER_EXE, tmp_dir, "DISPLAY=:4242", "--frames 1");
    vt_assert_exit(r, 1);
    assert_non_null(strstr(r.err, "cannot open a window"));
    vt_run_free(&r);
}

static void test_default_world(void **state)
{
    (void)state;
    if (!have_xvfb())
        skip();
    vt_run_result r = run_viewer("--scene gen:default --camera " CAM_DEFAULT " --frames 3 --no-hud --overlay ids "
                                 "--screenshot '%s' --drawlist '%s'",
                                 tmp_path("default.png"), tmp_path("default.txt"));
    vt_assert_exit(r, 0);
    vis_cull_list("gen:default", CAM_DEFAULT, tmp_path("default_ref.txt"));
    assert_same_file(tmp_path("default.txt"), tmp_path("default_ref.txt"));
    palette pal;
    world_palette("gen:default", &pal);
    check_picture(tmp_path("default.png"), r.out, &pal, 0.9);
    vt_run_free(&r);
}

/* The traversal-cost heat map beside the frame: the panel right of the 3D view holds the
 * ramp's cool end (the cheap sky and near pixels) and its warm end (the dearest). */
static void test_cost_overlay(void **state)
{
    (void)state;
    if (!have_xvfb())
        skip();
    vt_run_result r = run_viewer("--scene gen:default --camera " CAM_DEFAULT " --frames 2 --no-hud --overlay cost "
                                 "--screenshot '%s'",
                                 tmp_path("cost.png"));
    vt_assert_exit(r, 0);
    int v[4];
    view_rect(r.out, v);
    picture p = read_png(tmp_path("cost.png"));
    size_t cool = 0, warm = 0, panel = 0;
    for (uint32_t y = 0; y < p.h; ++y)
        for (uint32_t x = (uint32_t)(v[0] + v[2]); x < p.w; ++x) {
            const unsigned char *c = &p.rgb[((size_t)y * p.w + x) * 3];
            ++panel;
            cool += c[2] > 200 && c[0] < 60 && c[1] < 60;
            warm += c[0] > 200 && c[2] < 90;
        }
    free(p.rgb);
    if (panel == 0 || cool < panel / 100 || warm == 0)
        fail_msg("cost panel: %zu pixels, %zu at the cheap end, %zu at the dear end", panel, cool, warm);
    vt_run_free(&r);
}

static void test_vox_scene(void **state)
{
    (void)state;
    if (!have_xvfb())
        skip();
    const char *vox = vt_shared_file(VOX_FILE);
    if (!vox)
        skip();
    char spec[1024];
    snprintf(spec, sizeof spec, "%s", vox);
    const char *cam = "110,70,110,0,-20,0";
    vt_run_result r = run_viewer("--scene '%s' --camera %s --frames 2 --no-hud --screenshot '%s' --drawlist '%s'", spec,
                                 cam, tmp_path("vox.png"), tmp_path("vox.txt"));
    vt_assert_exit(r, 0);
    vis_cull_list(spec, cam, tmp_path("vox_ref.txt"));
    assert_same_file(tmp_path("vox.txt"), tmp_path("vox_ref.txt"));
    palette pal;
    world_palette(spec, &pal);
    assert_true(pal.materials > 4); /* a real palette, not one colour */
    check_picture(tmp_path("vox.png"), r.out, &pal, 0.9);
    vt_run_free(&r);
}

/* Culling frozen at one camera, drawn from another: the draw list is the frozen camera's,
 * and the frustum (yellow) and culled boxes (red) are in the picture. */
static void test_frozen(void **state)
{
    (void)state;
    if (!have_xvfb())
        skip();
    const char *draw_cam = "700,260,800,256,40,256";
    vt_run_result r = run_viewer("--camera %s --cull-camera " CAM_DEFAULT " --boxes --frames 2 --screenshot '%s' "
                                 "--drawlist '%s'",
                                 draw_cam, tmp_path("frozen.png"), tmp_path("frozen.txt"));
    vt_assert_exit(r, 0);
    vis_cull_list("gen:default", CAM_DEFAULT, tmp_path("frozen_ref.txt"));
    assert_same_file(tmp_path("frozen.txt"), tmp_path("frozen_ref.txt"));
    /* The view from elsewhere differs from the frozen camera's own list. */
    vis_cull_list("gen:default", draw_cam, tmp_path("drawcam_ref.txt"));
    char *a = vt_slurp(tmp_path("frozen.txt")), *b = vt_slurp(tmp_path("drawcam_ref.txt"));
    assert_string_not_equal(a, b);
    free(a), free(b);
    size_t yellow = count_colour(tmp_path("frozen.png"), 255, 255, 0);
    size_t red = count_colour(tmp_path("frozen.png"), 255, 48, 48);
    print_message("frozen frame: %zu frustum pixels, %zu culled-box pixels\n", yellow, red);
    assert_true(yellow > 100);
    assert_true(red > 100);
    vt_run_free(&r);
}

/* The draw list of `spec` for camera (eye/target) in-process, after applying `edit` (a cube
 * brush of radius r at v, set to value or, for add, empty voxels only). */
static char *reference_list_after_edit(const char *spec, const vis_camera *cam, const int64_t v[3], int radius,
                                       int tool_remove, uint32_t *out_pixel_id, uint32_t px, uint32_t py)
{
    vw_world *w = NULL;
    vw_error err;
    if (vw_world_from_spec(spec, NULL, NULL, NULL, &w, &err) != VW_OK)
        fail_msg("%s: %s", spec, err.message);
    vis_context_desc cd;
    vis_context_desc_defaults(&cd);
    cd.backend = VIS_BACKEND_CPU;
    vis_context *ctx;
    assert_int_equal(vis_context_create(&cd, &ctx), VIS_OK);
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    size_t n = (size_t)td.width * td.height;
    uint32_t *ids = malloc(n * sizeof *ids);
    assert_non_null(ids);
    /* Before the edit: which object is under the edit's pixel. */
    world_scene *ws;
    assert_int_equal(world_scene_create(ctx, w, NULL, &ws, NULL, &err), 0);
    assert_int_equal(vis_trace(ctx, world_scene_scene(ws), cam, &td, ids, n, NULL, 0), VIS_OK);
    *out_pixel_id = ids[(size_t)py * td.width + px];
    world_scene_destroy(ws);
    assert_true(tool_remove);
    for (int64_t z = v[2] - radius; z <= v[2] + radius; ++z)
        for (int64_t y = v[1] - radius; y <= v[1] + radius; ++y)
            for (int64_t x = v[0] - radius; x <= v[0] + radius; ++x)
                vw_world_set(w, x, y, z, 0);
    /* A scene built from scratch over the edited world. */
    vw_world_clear_dirty(w);
    assert_int_equal(world_scene_create(ctx, w, NULL, &ws, NULL, &err), 0);
    vis_scene *scene = world_scene_scene(ws);
    assert_int_equal(vis_trace(ctx, scene, cam, &td, ids, n, NULL, 0), VIS_OK);
    size_t cap = vis_drawlist_bound(scene), count = 0;
    vis_draw_entry *e = malloc(cap * sizeof *e);
    assert_int_equal(vis_drawlist_build(ctx, scene, ids, td.width, td.height, VIS_IDS_OBJECT, e, cap, &count), VIS_OK);
    char *text = malloc(count * 24 + 1);
    size_t len = 0;
    text[0] = '\0';
    for (size_t i = 0; i < count; ++i)
        len += (size_t)sprintf(text + len, "%u %u\n", e[i].id, e[i].pixels);
    free(e);
    free(ids);
    world_scene_destroy(ws);
    vis_context_destroy(ctx);
    vw_world_destroy(w);
    return text;
}

static void test_edit(void **state)
{
    (void)state;
    if (!have_xvfb())
        skip();
    const uint32_t px = 256, py = 300;
    vt_run_result r = run_viewer("--camera " CAM_DEFAULT " --edit remove:%u,%u,6 --frames 3 --no-hud --screenshot '%s' "
                                 "--drawlist '%s'",
                                 px, py, tmp_path("edit.png"), tmp_path("edit.txt"));
    vt_assert_exit(r, 0);
    const char *line = strstr(r.out, "edit remove r6 at voxel ");
    assert_non_null(line);
    long long v[3];
    unsigned object;
    unsigned long long changed;
    assert_int_equal(sscanf(line, "edit remove r6 at voxel %lld,%lld,%lld (object %u) material %*u: %llu voxels", &v[0],
                            &v[1], &v[2], &object, &changed),
                     5);
    assert_true(changed > 0);
    vis_camera cam = {{100, 120, -60}, {256, 40, 256}, 60, 0, 0};
    const int64_t c[3] = {v[0], v[1], v[2]};
    uint32_t pixel_id = 0;
    char *want = reference_list_after_edit("gen:default", &cam, c, 6, 1, &pixel_id, px, py);
    /* Picking went through the right pixel: the object hit there before the edit. */
    assert_int_equal(object, pixel_id);
    char *got = vt_slurp(tmp_path("edit.txt"));
    if (strcmp(got, want) != 0)
        fail_msg("the viewer's draw list after the edit differs from one built from scratch");
    /* And the edit changed what culling sees. */
    vis_cull_list("gen:default", CAM_DEFAULT, tmp_path("unedited.txt"));
    char *before = vt_slurp(tmp_path("unedited.txt"));
    assert_string_not_equal(before, got);
    palette pal;
    world_palette("gen:default", &pal);
    check_picture(tmp_path("edit.png"), r.out, &pal, 0.9);
    free(before), free(got), free(want);
    vt_run_free(&r);
}

/* Live switches through the keys (--keys: one press per frame): overlay, boxes, help, tool,
 * then M twice (ray pass -> leaf IDs -> z-buffer culler) and P (512^2 -> 1024^2). The last
 * frame's list must be the z-buffer culler's at 1024^2, as `vis cull` gives it. */
static void test_live_switches(void **state)
{
    (void)state;
    if (!have_xvfb())
        skip();
    vt_run_result r = run_viewer("--camera " CAM_DEFAULT " --frames 8 --keys OCHTMMP --drawlist '%s'",
                                 tmp_path("keys.txt"));
    vt_assert_exit(r, 0);
    assert_non_null(strstr(r.out, "z-buffer culler"));
    assert_non_null(strstr(r.out, "pass 1024x1024"));
    vt_run_result c = vt_run(VIS_EXE, tmp_dir, NULL,
                             "cull --scene gen:default --camera " CAM_DEFAULT " --method zbuf --res 1024x1024 "
                             "--dump-list '%s'",
                             tmp_path("keys_ref.txt"));
    vt_assert_exit(c, 0);
    assert_same_file(tmp_path("keys.txt"), tmp_path("keys_ref.txt"));
    vt_run_free(&c);
    vt_run_free(&r);
}

/* A small city with glass (see-through, reflective) seen from a roof: every effect changes
 * the list there (fog 60 culls direct objects; two objects are there only in reflections,
 * two only as shadow casters: tests/test_effects.c checks the effects themselves). */
#define CITY "gen:city:size=128x48x128:seed=2"
#define CAM_CITY "12.8,43,12.8,77,10,90"
#define CITY_EFFECTS "see-through,reflect,shadows:1,0.7,0.4,fog:60"

static void vis_cull_effects_list(const char *effects, const char *out_path)
{
    vt_run_result r = vt_run(VIS_EXE, tmp_dir, NULL,
                             "cull --scene " CITY " --camera " CAM_CITY " --res 256x256 --backend cpu --effects %s --dump-list '%s'",
                             effects, out_path);
    vt_assert_exit(r, 0);
    vt_run_free(&r);
}

/* Lines of an effects list ("ID DIRECT SEE_THROUGH REFLECTION SHADOW") with no direct pixel
 * and a pixel of column `col` (2 see-through, 3 reflection, 4 shadow). */
static int effect_only_entries(const char *path, int col)
{
    char *text = vt_slurp(path);
    assert_non_null(text);
    int n = 0;
    for (const char *p = text; *p;) {
        unsigned v[5];
        assert_int_equal(sscanf(p, "%u %u %u %u %u", &v[0], &v[1], &v[2], &v[3], &v[4]), 5);
        n += v[1] == 0 && v[col] > 0;
        p = strchr(p, '\n');
        assert_non_null(p);
        ++p;
    }
    free(text);
    return n;
}

/* --effects: the list drawn is `vis cull --effects`'s, byte for byte, with its reasons. */
static void test_effects_list(void **state)
{
    (void)state;
    if (!have_xvfb())
        skip();
    vt_run_result r = run_viewer("--scene " CITY " --camera " CAM_CITY " --res 256x256 --effects " CITY_EFFECTS
                                 " --frames 2 --no-hud --drawlist '%s'",
                                 tmp_path("fx.txt"));
    vt_assert_exit(r, 0);
    vis_cull_effects_list(CITY_EFFECTS, tmp_path("fx_ref.txt"));
    assert_same_file(tmp_path("fx.txt"), tmp_path("fx_ref.txt"));
    /* The view is one where the effects matter: objects there for a reflection or a shadow
     * alone, and a list unlike the plain one. */
    assert_true(effect_only_entries(tmp_path("fx.txt"), 3) > 0);
    assert_true(effect_only_entries(tmp_path("fx.txt"), 4) > 0);
    vt_run_free(&r);
}

/* Keys 1-4 (one press per frame): every effect on, then off again, ends on the plain list;
 * on alone they give the documented light and fog (1,0.7,0.4 and 200); and the z-buffer
 * culler ignores --effects. */
static void test_effects_keys(void **state)
{
    (void)state;
    if (!have_xvfb())
        skip();
    vt_run_result r = run_viewer("--scene " CITY " --camera " CAM_CITY " --res 256x256 --frames 9 --no-hud --keys "
                                 "12344321 --drawlist '%s'",
                                 tmp_path("fx_keys_off.txt"));
    vt_assert_exit(r, 0);
    vt_run_free(&r);
    vt_run_result c = vt_run(VIS_EXE, tmp_dir, NULL,
                             "cull --scene " CITY " --camera " CAM_CITY " --res 256x256 --dump-list '%s'",
                             tmp_path("fx_plain_ref.txt"));
    vt_assert_exit(c, 0);
    vt_run_free(&c);
    assert_same_file(tmp_path("fx_keys_off.txt"), tmp_path("fx_plain_ref.txt"));

    r = run_viewer("--scene " CITY " --camera " CAM_CITY " --res 256x256 --frames 5 --no-hud --keys 4321 "
                   "--drawlist '%s'",
                   tmp_path("fx_keys_on.txt"));
    vt_assert_exit(r, 0);
    vt_run_free(&r);
    vis_cull_effects_list("see-through,reflect,shadows:1,0.7,0.4,fog:200", tmp_path("fx_keys_on_ref.txt"));
    assert_same_file(tmp_path("fx_keys_on.txt"), tmp_path("fx_keys_on_ref.txt"));

    r = run_viewer("--scene " CITY " --camera " CAM_CITY " --res 256x256 --method zbuf --effects " CITY_EFFECTS
                   " --frames 1 --no-hud --drawlist '%s'",
                   tmp_path("fx_zbuf.txt"));
    vt_assert_exit(r, 0);
    vt_run_free(&r);
    c = vt_run(VIS_EXE, tmp_dir, NULL,
               "cull --scene " CITY " --camera " CAM_CITY " --res 256x256 --method zbuf --dump-list '%s'",
               tmp_path("fx_zbuf_ref.txt"));
    vt_assert_exit(c, 0);
    vt_run_free(&c);
    assert_same_file(tmp_path("fx_zbuf.txt"), tmp_path("fx_zbuf_ref.txt"));
}

/* Key B with effects on: the OpenCL backend's vis_trace_effects traces the last frames, and
 * the list is the CPU's `vis cull --effects` list byte for byte. Without an OpenCL device
 * the viewer stays on the CPU (its HUD says why) and only that is checked. */
static void test_effects_opencl(void **state)
{
    (void)state;
    if (!have_xvfb())
        skip();
    vt_run_result r = run_viewer("--scene " CITY " --camera " CAM_CITY " --res 256x256 --backend cpu --effects "
                                 CITY_EFFECTS " --frames 3 --keys B --no-hud --drawlist '%s'",
                                 tmp_path("fx_cl.txt"));
    vt_assert_exit(r, 0);
    if (!strstr(r.out, "object IDs, opencl ("))
        print_message("NOTE: no OpenCL device: key B left the viewer on the CPU; the OpenCL list is not checked\n");
    vis_cull_effects_list(CITY_EFFECTS, tmp_path("fx_cl_ref.txt"));
    assert_same_file(tmp_path("fx_cl.txt"), tmp_path("fx_cl_ref.txt"));
    vt_run_free(&r);
}

/* Pixels of one tint (docs/viewer.md: cyan 0,255,255 seen through only, magenta 255,0,255
 * in reflections only, orange 255,128,0 shadow casters only) times any face shade, within
 * 1 per channel (GL's conversion to 8 bits). */
static size_t count_tint(const char *png_path, const unsigned char tint[3])
{
    static const float shades[4] = {1.0f, 0.5f, 0.8f, 0.65f};
    unsigned char want[4][3];
    for (int s = 0; s < 4; ++s)
        for (int k = 0; k < 3; ++k)
            want[s][k] = (unsigned char)lroundf((float)tint[k] * shades[s]);
    picture p = read_png(png_path);
    size_t n = 0;
    for (size_t i = 0; i < (size_t)p.w * p.h; ++i) {
        const unsigned char *c = &p.rgb[3 * i];
        for (int s = 0; s < 4; ++s)
            if (abs(c[0] - want[s][0]) <= 1 && abs(c[1] - want[s][1]) <= 1 && abs(c[2] - want[s][2]) <= 1) {
                ++n;
                break;
            }
    }
    free(p.rgb);
    return n;
}

/* Culling frozen on the roof with effects, drawn from above the city: the objects there
 * only in a reflection (magenta) and only as shadow casters (orange) are in the picture;
 * without --effects neither colour is. */
static void test_effects_tint(void **state)
{
    (void)state;
    if (!have_xvfb())
        skip();
    static const unsigned char magenta[3] = {255, 0, 255}, orange[3] = {255, 128, 0}, cyan[3] = {0, 255, 255};
    const char *above = "-60,150,-60,64,0,64";
    vt_run_result r = run_viewer("--scene " CITY " --camera %s --cull-camera " CAM_CITY " --res 256x256 --effects "
                                 CITY_EFFECTS " --frames 2 --no-hud --screenshot '%s'",
                                 above, tmp_path("fx_tint.png"));
    vt_assert_exit(r, 0);
    vt_run_free(&r);
    r = run_viewer("--scene " CITY " --camera %s --cull-camera " CAM_CITY " --res 256x256 --frames 2 --no-hud "
                   "--screenshot '%s'",
                   above, tmp_path("fx_plain.png"));
    vt_assert_exit(r, 0);
    vt_run_free(&r);
    size_t m = count_tint(tmp_path("fx_tint.png"), magenta), o = count_tint(tmp_path("fx_tint.png"), orange);
    size_t m0 = count_tint(tmp_path("fx_plain.png"), magenta), o0 = count_tint(tmp_path("fx_plain.png"), orange);
    size_t c0 = count_tint(tmp_path("fx_plain.png"), cyan);
    print_message("tints with effects: %zu reflection, %zu shadow-caster pixels; without: %zu, %zu (cyan %zu)\n", m,
                  o, m0, o0, c0);
    assert_true(m > 100);
    assert_true(o > 100);
    assert_int_equal(m0, 0);
    assert_int_equal(o0, 0);
    assert_int_equal(c0, 0);
}

static void test_bad_arguments(void **state)
{
    (void)state;
    vt_run_result r = vt_run(VIEWER_EXE, tmp_dir, NULL, "--res 0x5");
    vt_assert_exit(r, 2);
    vt_run_free(&r);
    r = vt_run(VIEWER_EXE, tmp_dir, NULL, "--screenshot x.png");
    vt_assert_exit(r, 2);
    assert_non_null(strstr(r.err, "--frames"));
    vt_run_free(&r);
    r = vt_run(VIEWER_EXE, tmp_dir, NULL, "--frames 1 --edit explode:1,1");
    vt_assert_exit(r, 2);
    vt_run_free(&r);
    /* A malformed --effects: exit 2 before any window, the message naming the problem. */
    static const struct {
        const char *args, *says;
    } fx[] = {{"--effects glitter", "glitter"},        {"--effects shadows:1,2", "shadows"},
              {"--effects shadows:0,0,0", "zero"},     {"--effects fog:-3", "fog"},
              {"--effects reflect,reflect", "twice"},  {"--effects ''", "effect"}};
    for (size_t i = 0; i < sizeof fx / sizeof fx[0]; ++i) {
        r = vt_run(VIEWER_EXE, tmp_dir, "env -u DISPLAY", "%s", fx[i].args);
        vt_assert_exit(r, 2);
        assert_non_null(strstr(r.err, "--effects"));
        if (!strstr(r.err, fx[i].says))
            fail_msg("%s: the message does not say '%s': %s", fx[i].args, fx[i].says, r.err);
        vt_run_free(&r);
    }
}

static int setup(void **state) { return vt_run_setup(state, tmp_dir, sizeof tmp_dir, "vis_test_viewer", VIEWER_EXE); }

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_no_display), cmocka_unit_test(test_bad_arguments), cmocka_unit_test(test_default_world),
        cmocka_unit_test(test_vox_scene),  cmocka_unit_test(test_frozen),        cmocka_unit_test(test_edit),
        cmocka_unit_test(test_live_switches),    cmocka_unit_test(test_cost_overlay),
        cmocka_unit_test(test_effects_list),     cmocka_unit_test(test_effects_keys),
        cmocka_unit_test(test_effects_tint),     cmocka_unit_test(test_effects_opencl),
    };
    return cmocka_run_group_tests(tests, setup, vt_tmp_dir_teardown);
}
