/* effects.h — the CPU's effects pass for one tile (effects.c, trace_core.h built with
 * VIS_TRACE_EFFECTS). */
#ifndef VIS_CPU_EFFECTS_H
#define VIS_CPU_EFFECTS_H

#include <stdint.h>

#include "backend.h"

/* Traces pixels [x0, x1) x [y0, y1) with the effects and writes every buffer `out` has;
 * returns the secondary rays cast. */
uint64_t vis_cpu_effects_tile(const vis_scene_view *view, const vis_ray_setup *setup, const vis_effect_setup *effects,
                          const vis_effect_outputs *out, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1);

#endif /* VIS_CPU_EFFECTS_H */
