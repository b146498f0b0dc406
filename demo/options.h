/* options.h — vis-viewer's command line. */
#ifndef VIS_VIEWER_OPTIONS_H
#define VIS_VIEWER_OPTIONS_H

#include <stdint.h>

#include "edit.h"
#include "effects_spec.h"
#include "viewer.h"

typedef struct vv_options {
    const char *scene;           /* default gen:default                                    */
    int have_camera;
    vv_view camera;              /* --camera                                               */
    uint32_t width, height;      /* --res: the pass, default 512x512                       */
    int win_w, win_h;            /* --window, default 960x600                              */
    vis_backend_kind backend;    /* --backend                                              */
    vv_method method;            /* --method ray|zbuf|none with --ids object|leaf          */
    vv_overlay overlay;          /* --overlay                                              */
    vc_effects effects;          /* --effects (bits 0: none), light and fog preset to
                                    cull.h's defaults for the keys that turn them on       */
    int boxes;                   /* --boxes: the culled objects' boxes                     */
    int hud;                     /* 0 with --no-hud                                        */
    /* The scripted mode: --frames N renders N frames and exits.                           */
    uint32_t frames;
    const char *screenshot;      /* of the last frame                                      */
    const char *drawlist;        /* the last frame's draw list, as `vis cull --dump-list`  */
    int freeze;                  /* --freeze: culling frozen at the first frame's camera   */
    int have_cull_camera;
    vv_view cull_camera;         /* --cull-camera: culling frozen at this camera           */
    int have_edit;               /* --edit TOOL:PX,PY[,R] before the second frame          */
    vv_tool edit_tool;
    double edit_px, edit_py;
    int edit_radius;
    uint8_t material;            /* --material N: for add and paint (default 1)            */
    const char *keys;            /* --keys: key presses, one per frame from the second on  */
} vv_options;

/* Parses argv. Returns VV_EXIT_OK, VV_EXIT_USAGE after printing the problem, or -1 after
 * printing --help (the caller exits 0). */
int vv_options_parse(int argc, char **argv, vv_options *out);

#endif
