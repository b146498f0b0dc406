/* options.c — the command line of vis-viewer. */
#include "options.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cull.h"
#include "names.h"

static const char *usage =
    "usage: vis-viewer [--scene SPEC] [--camera EX,EY,EZ,TX,TY,TZ[,FOVY]] [--res WxH] [--window WxH]\n"
    "                  [--backend auto|cpu|opencl] [--method ray|zbuf|none] [--ids object|leaf]\n"
    "                  [--overlay none|ids|depth|cost] [--boxes] [--no-hud] [--material N]\n"
    "                  [--effects see-through,reflect,shadows:DX,DY,DZ,fog:DIST]\n"
    "  scripted mode:  --frames N [--screenshot FILE.png] [--drawlist FILE] [--freeze]\n"
    "                  [--cull-camera EX,EY,EZ,TX,TY,TZ[,FOVY]] [--edit add|remove|paint:PX,PY[,R]]\n"
    "                  [--keys KEYS]\n"
    "SPEC is any scene `vis` takes (gen:NAME[:k=v...], a .vox or .vdb file); default gen:default.\n"
    "--res is the pass (each side 1..1024; the 3D view takes its aspect). Without --camera the\n"
    "scripted mode flies the camera path of `vis run`, one view per frame. --drawlist writes the\n"
    "last frame's draw list as `vis cull --dump-list` does (ID PIXELS per line); --cull-camera\n"
    "freezes culling at that camera while the view is --camera; --edit edits at pixel (PX, PY)\n"
    "of the pass with a brush of radius R (default 0) before the second frame; --keys presses\n"
    "the keys of KEYS (letters, digits and [ ] , .), one per frame from the second frame on.\n"
    "--effects (as `vis cull --effects`) starts with those effects on (keys 1-4 toggle them)\n"
    "and sets the light and fog the keys use (default shadows:1,0.7,0.4 and fog:200); the ray\n"
    "pass with object IDs traces them, the other methods ignore them. With effects on,\n"
    "--drawlist writes `vis cull --effects ... --dump-list`'s five columns.\n";

static int usage_error(const char *fmt, const char *arg)
{
    fprintf(stderr, "vis-viewer: ");
    fprintf(stderr, fmt, arg);
    fprintf(stderr, "\n(vis-viewer --help lists the options)\n");
    return VV_EXIT_USAGE;
}

static int parse_wxh(const char *s, uint32_t lo, uint32_t hi, uint32_t *w, uint32_t *h)
{
    char *end;
    errno = 0;
    unsigned long a = strtoul(s, &end, 10);
    if (end == s || *end != 'x' || errno)
        return -1;
    const char *p = end + 1;
    unsigned long b = strtoul(p, &end, 10);
    if (end == p || *end || errno || a < lo || a > hi || b < lo || b > hi)
        return -1;
    *w = (uint32_t)a;
    *h = (uint32_t)b;
    return 0;
}

static int parse_uint(const char *s, unsigned long hi, unsigned long *out)
{
    char *end;
    errno = 0;
    unsigned long v = strtoul(s, &end, 10);
    if (end == s || *end || errno || v > hi || s[0] == '-')
        return -1;
    *out = v;
    return 0;
}

static int parse_edit(const char *s, vv_options *o)
{
    const char *colon = strchr(s, ':');
    if (!colon || colon - s > 15)
        return -1;
    char tool[16];
    memcpy(tool, s, (size_t)(colon - s));
    tool[colon - s] = '\0';
    int t = vv_tool_parse(tool);
    if (t < 0)
        return -1;
    double px, py;
    int r = 0, n = 0;
    char extra;
    int got = sscanf(colon + 1, "%lf,%lf%n,%d%c", &px, &py, &n, &r, &extra);
    if (got < 2 || got > 3 || (got == 2 && colon[1 + n] != '\0') || r < 0 || r > 32)
        return -1;
    o->have_edit = 1;
    o->edit_tool = (vv_tool)t;
    o->edit_px = px;
    o->edit_py = py;
    o->edit_radius = r;
    return 0;
}

int vv_options_parse(int argc, char **argv, vv_options *o)
{
    memset(o, 0, sizeof *o);
    o->scene = "gen:default";
    o->width = o->height = 512;
    o->win_w = 960;
    o->win_h = 600;
    o->backend = VIS_BACKEND_AUTO;
    o->method = VV_METHOD_RAY_OBJECT;
    o->hud = 1;
    o->material = 1;
    o->effects.light[0] = VV_DEFAULT_LIGHT_X;
    o->effects.light[1] = VV_DEFAULT_LIGHT_Y;
    o->effects.light[2] = VV_DEFAULT_LIGHT_Z;
    o->effects.fog = VV_DEFAULT_FOG;
    int zbuf = 0, none = 0, leaf = 0;
    for (int i = 1; i < argc; ++i) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(usage, stdout);
            return -1;
        }
        if (!strcmp(a, "--boxes")) {
            o->boxes = 1;
            continue;
        }
        if (!strcmp(a, "--no-hud")) {
            o->hud = 0;
            continue;
        }
        if (!strcmp(a, "--freeze")) {
            o->freeze = 1;
            continue;
        }
        if (i + 1 >= argc)
            return usage_error("%s needs a value", a);
        const char *v = argv[++i];
        unsigned long n;
        int k;
        if (!strcmp(a, "--scene")) {
            o->scene = v;
        } else if (!strcmp(a, "--camera")) {
            if (vv_view_parse(v, &o->camera) != 0)
                return usage_error("--camera wants EX,EY,EZ,TX,TY,TZ[,FOVY] (fovy in (0, 180)), not \"%s\"", v);
            o->have_camera = 1;
        } else if (!strcmp(a, "--cull-camera")) {
            if (vv_view_parse(v, &o->cull_camera) != 0)
                return usage_error("--cull-camera wants EX,EY,EZ,TX,TY,TZ[,FOVY], not \"%s\"", v);
            o->have_cull_camera = 1;
        } else if (!strcmp(a, "--res")) {
            if (parse_wxh(v, 1, 1024, &o->width, &o->height) != 0)
                return usage_error("--res wants WxH with each side 1..1024, not \"%s\"", v);
        } else if (!strcmp(a, "--window")) {
            uint32_t w, h;
            if (parse_wxh(v, 64, 8192, &w, &h) != 0)
                return usage_error("--window wants WxH with each side 64..8192, not \"%s\"", v);
            o->win_w = (int)w, o->win_h = (int)h;
        } else if (!strcmp(a, "--backend")) {
            if (vc_name_lookup(&vc_backends, v, &k) != 0)
                return usage_error("--backend wants auto, cpu or opencl, not \"%s\"", v);
            o->backend = (vis_backend_kind)k;
        } else if (!strcmp(a, "--method")) {
            if (!strcmp(v, "ray"))
                zbuf = none = 0;
            else if (!strcmp(v, "zbuf"))
                zbuf = 1, none = 0;
            else if (!strcmp(v, "none"))
                none = 1, zbuf = 0;
            else
                return usage_error("--method wants ray, zbuf or none, not \"%s\"", v);
        } else if (!strcmp(a, "--ids")) {
            if (vc_name_lookup(&vc_id_modes, v, &k) != 0)
                return usage_error("--ids wants object or leaf, not \"%s\"", v);
            leaf = k == VIS_IDS_LEAF;
        } else if (!strcmp(a, "--overlay")) {
            if (!strcmp(v, "none"))
                o->overlay = VV_OVERLAY_NONE;
            else if (!strcmp(v, "ids"))
                o->overlay = VV_OVERLAY_IDS;
            else if (!strcmp(v, "depth"))
                o->overlay = VV_OVERLAY_DEPTH;
            else if (!strcmp(v, "cost"))
                o->overlay = VV_OVERLAY_COST;
            else
                return usage_error("--overlay wants none, ids, depth or cost, not \"%s\"", v);
        } else if (!strcmp(a, "--frames")) {
            if (parse_uint(v, 100000, &n) != 0 || n == 0)
                return usage_error("--frames wants 1..100000, not \"%s\"", v);
            o->frames = (uint32_t)n;
        } else if (!strcmp(a, "--material")) {
            if (parse_uint(v, 255, &n) != 0 || n == 0)
                return usage_error("--material wants 1..255, not \"%s\"", v);
            o->material = (uint8_t)n;
        } else if (!strcmp(a, "--screenshot")) {
            o->screenshot = v;
        } else if (!strcmp(a, "--effects")) {
            char err[256];
            if (vc_effects_parse(v, &o->effects, err, sizeof err) != 0)
                return usage_error("--effects: %s", err);
        } else if (!strcmp(a, "--keys")) {
            for (const char *c = v; *c; ++c)
                if (!((*c >= 'A' && *c <= 'Z') || (*c >= 'a' && *c <= 'z') || (*c >= '0' && *c <= '9') ||
                      strchr("[],.", *c)))
                    return usage_error("--keys takes letters, digits and [ ] , . only, not \"%s\"", v);
            o->keys = v;
        } else if (!strcmp(a, "--drawlist")) {
            o->drawlist = v;
        } else if (!strcmp(a, "--edit")) {
            if (parse_edit(v, o) != 0)
                return usage_error("--edit wants add|remove|paint:PX,PY[,R] (R 0..32), not \"%s\"", v);
        } else {
            --i;
            return usage_error("unknown option %s", a);
        }
    }
    o->method = none ? VV_METHOD_NONE : zbuf ? VV_METHOD_ZBUF : leaf ? VV_METHOD_RAY_LEAF : VV_METHOD_RAY_OBJECT;
    if (!o->frames && (o->screenshot || o->drawlist || o->freeze || o->have_cull_camera || o->have_edit || o->keys))
        return usage_error("%s", "--screenshot, --drawlist, --freeze, --cull-camera, --edit and --keys belong to "
                                 "the scripted mode: add --frames N");
    if (o->keys && strlen(o->keys) >= o->frames)
        return usage_error("%s", "--keys: one key per frame from the second on needs more --frames than keys");
    if (o->have_edit && (o->edit_px < 0 || o->edit_py < 0 || o->edit_px >= o->width || o->edit_py >= o->height))
        return usage_error("%s", "--edit: the pixel lies outside the pass (--res)");
    return VV_EXIT_OK;
}
