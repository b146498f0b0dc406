/*
 * accuracy.h — the arithmetic of `vis accuracy`: one draw list against the ground truth of
 * the same view (DESIGN.md, "accuracy"), the averages over a camera path, and the pieces of
 * the study that are easy to get subtly wrong (buffer sizes of the display's aspect, the
 * frustum test that says which objects a camera could see at all).
 *
 * Ground truth: the object-ID ray pass at display resolution (optionally supersampled). Its
 * draw list holds every object with at least one sample, with that sample count; an object's
 * visible area is samples / total samples (a fraction of the display).
 *
 * Nothing here allocates, prints or touches a context; everything is plain arithmetic on
 * caller-owned arrays, so the tests can feed it hand-made draw lists.
 */
#ifndef VIS_TOOLS_ACCURACY_H
#define VIS_TOOLS_ACCURACY_H

#include <stddef.h>
#include <stdint.h>

#include "vis/vis.h"

/* What one method's draw list gets right and wrong in one view. */
typedef struct vc_accuracy {
    uint32_t truth_visible;      /* objects with >= 1 truth sample                            */
    uint32_t drawn;              /* entries of the method's draw list                         */
    uint32_t missed;             /* visible, not drawn: they pop in                           */
    double missed_area;          /* sum of the missed objects' truth areas, fraction of the
                                    display (0..1): the popping a player would see            */
    uint32_t overdraw;           /* drawn, not visible                                        */
    uint64_t overdraw_triangles; /* their triangles (a quad counts as 2); 0 without a table   */
    uint32_t hidden;             /* in the view frustum but not visible (occluded, or between
                                    the truth's samples); 0 without an in-view table          */
    uint32_t hidden_culled;      /* of those, the ones left out of the draw list              */
    /* With effects (vc_accuracy_reasons; zeros otherwise), per VIS_REASON_* bit i: */
    uint32_t reason_truth[VIS_REASON_COUNT];  /* truth objects listed with reason i            */
    uint32_t reason_missed[VIS_REASON_COUNT]; /* of those, the ones absent from the draw list  */
} vc_accuracy;

/* Per-object facts the comparison may use, indexed by object ID (0..id_count-1); each
 * pointer may be NULL. */
typedef struct vc_accuracy_objects {
    const uint32_t *triangles;   /* triangles of the object (quads x 2 + triangles)           */
    const uint8_t *in_view;      /* 1 when the object's box meets the view frustum            */
    uint32_t id_count;           /* the arrays' length (max ID + 1)                           */
} vc_accuracy_objects;

/* Compares a draw list with the truth of the same view. Both lists must be sorted by
 * ascending ID without repeats (as vis_drawlist_build and vis_zcull_run give them); a
 * truth entry with pixels = 0 counts as not visible. truth_samples is the truth's total
 * sample count (W*H, times 4 with 2x2 supersampling). objects may be NULL. IDs at or above
 * objects->id_count count no triangles and are never in view. Returns 0, or -1 (and leaves
 * *out untouched) when a list is not sorted or truth_samples is 0 while truth has pixels. */
int vc_accuracy_compare(const vis_draw_entry *truth, size_t truth_count, uint64_t truth_samples,
                        const vis_draw_entry *drawn, size_t drawn_count, const vc_accuracy_objects *objects,
                        vc_accuracy *out);

/* The misses per reason of an effects truth (vis_drawlist_build_effects's list, sorted by
 * ascending ID): for each reason bit i, how many truth objects carry it (truth_objects[i]) and
 * how many of those the drawn list lacks altogether (missed[i]). An object with several
 * reasons counts under each, so the reasons may sum to more than vc_accuracy.missed. A drawn
 * object that lacks only one of its reasons is not a miss: the renderer draws it, and the
 * drawn list of a pass without effects (the z-buffer culler) has no reasons to compare.
 * Returns 0, or -1 (outputs untouched) when a list is not sorted without repeats. */
int vc_accuracy_reasons(const vis_effect_entry *truth, size_t truth_count, const vis_draw_entry *drawn,
                        size_t drawn_count, uint32_t truth_objects[VIS_REASON_COUNT],
                        uint32_t missed[VIS_REASON_COUNT]);

/* The average of one method over the frames of a camera path. */
typedef struct vc_accuracy_summary {
    uint32_t frames;
    double truth_visible;        /* means over the frames                                     */
    double drawn;
    double missed;
    double missed_area;          /* mean fraction of the display                              */
    double missed_area_max;      /* the worst frame                                           */
    double overdraw;
    double overdraw_triangles;
    double hidden;
    double occluded_culled;      /* sum of hidden_culled / sum of hidden over the frames (pooled,
                                    not a mean of ratios); 1 when nothing was hidden          */
    double reason_truth[VIS_REASON_COUNT];  /* means of vc_accuracy's per-reason counts       */
    double reason_missed[VIS_REASON_COUNT];
} vc_accuracy_summary;

/* Averages n >= 0 frames (n = 0 gives zeros and occluded_culled = 1). */
void vc_accuracy_summarize(const vc_accuracy *frames, size_t n, vc_accuracy_summary *out);

/* The buffer of the display's aspect ratio with about pixels_w * pixels_h pixels: what a game
 * budgeting 512x512 rays for a 1920x1080 display traces (683x384), since a buffer's aspect
 * W/H sets its horizontal field of view and a square buffer would see a narrower view than a
 * wide display. Height = round(sqrt(pixels / aspect)), width = round(height * aspect); each
 * at least 1 and at most VIS_MAX_RESOLUTION. */
void vc_accuracy_buffer_size(uint32_t pixels_w, uint32_t pixels_h, uint32_t display_w, uint32_t display_h,
                             uint32_t *out_w, uint32_t *out_h);

/* 1 when the box [lo, hi] (world units) may meet the view frustum of `camera` on a buffer of
 * aspect W/H, 0 when it lies wholly outside one of its planes (left, right, top, bottom,
 * near, far). Conservative like any plane test: a box beside a frustum corner can pass. Uses
 * the camera frame of DESIGN.md (double precision; fovy 0 means 60, near 0 means 0.05). */
int vc_box_in_view(const vis_camera *camera, uint32_t width, uint32_t height, const double lo[3],
                   const double hi[3]);

#endif
