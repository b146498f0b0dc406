/*
 * vox_format.h — MagicaVoxel .vox internals shared by vox_read.c, vox_write.c, the tests
 * and the fuzz harness (never installed).
 *
 * Format: ephtracy/voxel-model, MagicaVoxel-file-format-vox.txt (RIFF-style chunks, SIZE,
 * XYZI, RGBA, the default palette, MATT) and MagicaVoxel-file-format-vox-extension.txt
 * (STRING, DICT, ROTATION, the nTRN/nGRP/nSHP scene graph, MATL, LAYR, rOBJ, rCAM, NOTE,
 * IMAP). docs/vox.md says what we read, what we skip and how coordinates map.
 */
#ifndef VOXELWORLD_VOX_FORMAT_H
#define VOXELWORLD_VOX_FORMAT_H

#include <stddef.h>
#include <stdint.h>

#include "voxelworld/vw.h"

/* The palette MagicaVoxel uses when a file has no RGBA chunk (format spec, section 8),
 * indexed by colour index; entry 0 is the empty voxel. 0xAABBGGRR, as vw_material.rgba. */
extern const uint32_t vw_vox_default_palette[256];

/* Caps on what one file may make us build, so that a small hostile file cannot ask for a
 * huge allocation or an endless scene-graph walk. Zero fields mean the default. */
typedef struct vw_vox_limits {
    uint32_t max_chunks;            /* world chunks (default 1<<22: a 64 MiB chunk table)   */
    uint32_t max_instances;         /* shape instances after the DAG is expanded (1<<18)   */
    uint64_t max_instanced_voxels;  /* sum of the instances' XYZI counts (1<<28)            */
    uint32_t max_node_visits;       /* scene-graph nodes visited while expanding (1<<24)   */
} vw_vox_limits;

/* What a load found; tests compare these with ../shared/data/ATTRIBUTION.md. */
typedef struct vw_vox_stats {
    uint32_t version;              /* 150, 200                                              */
    uint32_t models;               /* SIZE/XYZI pairs                                       */
    uint64_t model_voxels;         /* sum of the models' XYZI counts ("xyzi")               */
    int32_t largest_model[3];      /* SIZE of the model with the most cells ("SIZE(largest)") */
    uint32_t nodes[3];             /* nTRN, nGRP, nSHP chunks                               */
    uint32_t layers;               /* LAYR chunks                                           */
    uint32_t instances;            /* visible shape instances: every DAG path is one ("inst") */
    uint32_t hidden_instances;     /* instances skipped (hidden node or layer)              */
    uint64_t instanced_voxels;     /* sum over visible instances of their model's XYZI count
                                      ("instvox"; overlapping instances count twice, so the
                                      world may hold fewer distinct voxels)                */
    uint32_t rotated_transforms;   /* nTRN visits (one per DAG path through the node) whose
                                      frame-0 rotation is not the identity ("rot")          */
    int has_palette;               /* 1: RGBA chunk; 0: the default palette                 */
    int has_index_map;             /* 1: an IMAP chunk was applied                          */
    /* Union of the visible instances' model boxes, in world coordinates (Y up), [min, max).
       All zero when there is no visible instance. */
    int64_t bounds_min[3];
    int64_t bounds_max[3];
} vw_vox_stats;

/* vw_vox_load_memory with explicit limits (NULL = defaults), the default vw_budget, and
 * statistics (may be NULL). out_world may be NULL: the file is then parsed, checked and
 * measured, and no world is built (nor the budget checked). */
vw_status vw_vox_load_memory_ex(const void *data, size_t size, int32_t chunk_size, const vw_vox_limits *limits,
                                vw_world **out_world, vw_vox_stats *out_stats, vw_error *err);

/* vw_vox_save_file into a malloc'ed buffer (caller frees *out_data). */
vw_status vw_vox_save_memory(const vw_world *world, void **out_data, size_t *out_size, vw_error *err);

#endif /* VOXELWORLD_VOX_FORMAT_H */
