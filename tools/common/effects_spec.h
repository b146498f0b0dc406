/* effects_spec.h — the effects list that `vis --effects` and `vis-viewer --effects` take
 * (docs/effects.md): "see-through,reflect,shadows:DX,DY,DZ,fog:DIST", any subset, any order,
 * each at most once. One parser and one printer of the names, so that both programs read the
 * same text the same way; and the see-through layers both ask for, so that their draw lists
 * (pixels per reason) agree. */
#ifndef VIS_TOOLS_EFFECTS_SPEC_H
#define VIS_TOOLS_EFFECTS_SPEC_H

#include <stddef.h>
#include <stdint.h>

#include "vis/vis.h"

/* See-through layers per pixel the tools trace (vis_trace_desc.see_through_layers). */
#define VC_SEE_THROUGH_LAYERS 2u

typedef struct vc_effects {
    uint32_t bits;   /* VIS_EFFECT_*                                                      */
    double light[3]; /* shadows:DX,DY,DZ (toward the light); set only when SHADOWS is named */
    double fog;      /* fog:DIST; set only when FOG is named                              */
} vc_effects;

/* 0 and *out when all of s is one finite number (strtod), -1 otherwise. The --effects list
 * reads its numbers with it, and so does vis's argument parser. */
int vc_parse_double(const char *s, double *out);

/* Parses a list into *out (bits from 0; light and fog left as they were unless named, so a
 * caller may preset defaults). Returns 0, or -1 with the problem in err ("unknown effect
 * 'glitter' (...)", "'reflect' given twice", "the light direction must not be zero", ...);
 * *out is then unspecified. */
int vc_effects_parse(const char *list, vc_effects *out, char *err, size_t err_size);

/* "see-through,reflect,shadows,fog": the names of the bits set, in that order ("" for 0). */
void vc_effects_format(uint32_t bits, char *out, size_t size);

#endif
