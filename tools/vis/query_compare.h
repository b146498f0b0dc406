/* query_compare.h — what `vis query --compare` measures beside libvis's answer on the same
 * replay: the dense truth, a SMAC-style entity check and Luanti-style entity and chunk checks
 * (docs/server.md, "Baselines"). */
#ifndef VIS_CLI_QUERY_COMPARE_H
#define VIS_CLI_QUERY_COMPARE_H

#include <stdint.h>

#include "vis/vis.h"

typedef struct qc_chunk {
    uint32_t id;            /* object ID (0: no object)                                    */
    double lo[3], hi[3];    /* the chunk's cell, world coordinates                         */
} qc_chunk;

/* SMAC-style: 10 segments per pair (the centre, a head point standing in for the weapon
 * tip, the 8 corners scaled by 1.3 across and 0.65 up), both ends extrapolated by velocity
 * x (latency + one tick), a reveal hold of hold_ticks, at most max_traces segments a tick
 * (pairs past it are reported). hold: viewers x entities counters (input positions), kept
 * by the caller across ticks. visible[v * ne + e] is set. Returns segments traced. */
uint64_t qc_smac(const vis_scene *scene, const vis_query_viewer *vw, uint32_t nv, const vis_query_entity *en,
                 uint32_t ne, double tick_ms, uint32_t hold_ticks, uint32_t max_traces, uint32_t *hold,
                 uint8_t *visible);

/* Luanti-style entities: 9 segments per pair (centre and the 8 corners of the box), no
 * extrapolation, no hold. Returns segments traced. */
uint64_t qc_luanti_entities(const vis_scene *scene, const vis_query_viewer *vw, uint32_t nv,
                            const vis_query_entity *en, uint32_t ne, uint8_t *visible);

/* Luanti-style chunks for one viewer: every chunk within range whose centre or one of its 8
 * corners is reached by a segment from the eye that stops 1 voxel short (Luanti's
 * isBlockOccluded, 9 rays per 16^3 block). sent[i] set per chunk. Returns segments traced. */
uint64_t qc_luanti_chunks(const vis_scene *scene, const double eye[3], const qc_chunk *chunks, uint32_t n,
                          double range, uint8_t *sent);

#endif
