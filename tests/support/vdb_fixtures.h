/* vdb_fixtures.h — test support for tests/test_vdb.c, written with OpenVDB in C++
 * (vdb_fixtures.cpp, linked only into test_vdb): small .vdb files with the cases the shared
 * data lacks, and a second reading of a grid to check an imported world against. */
#ifndef VIS_VDB_FIXTURES_H
#define VIS_VDB_FIXTURES_H

#include <stdint.h>

#include "voxelworld/vw.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Writes the fixture `kind` (see vdb_fixtures.cpp for the list) to `path`. 0 on success;
 * otherwise prints why to stderr and returns 1. */
int vt_vdb_write_fixture(const char *path, const char *kind);

/* Reads the grid (NULL: the first float or double grid) with openvdb::io::File, probes every
 * index voxel of its active bounding box grown by two through a ValueAccessor by the
 * importer's rules (level set: value < 0; otherwise active and value > fog_threshold), and
 * compares with vw_world_get. 0 on success (then *out_solid and *out_mismatches are set). */
int vt_vdb_compare(const char *path, const char *grid_name, float fog_threshold, const vw_world *world,
                   uint64_t *out_solid, uint64_t *out_mismatches);

#ifdef __cplusplus
}
#endif

#endif
