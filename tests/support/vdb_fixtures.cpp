/*
 * vdb_fixtures.cpp — test support for tests/test_vdb.c (see vdb_fixtures.h): .vdb files
 * written with OpenVDB for the cases the shared data lacks, and an independent second
 * reading of a grid (openvdb::io::File and a ValueAccessor, not the importer's archive or
 * traversal). Linked only into test_vdb (tests/vdb_fixtures.cmake); not part of libvis.
 */
#include "vdb_fixtures.h"

#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>

#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

namespace {

namespace vdb = openvdb;

vdb::FloatGrid::Ptr fixture_fog(const char *name, vdb::GridClass cls)
{
    vdb::FloatGrid::Ptr g = vdb::FloatGrid::create(0.0f);
    g->setName(name);
    g->setGridClass(cls);
    return g;
}

/* Kinds: multi, vector, tiles, fogtile, xform, rotated, instance, stream, empty (the
 * original cases), liar (metadata that disagrees with the tree), deep (a level set
 * interior over the default voxel budget), scatter (4096 chunks that must be dense). */
void write_fixture(const char *path, const std::string &kind)
{
    vdb::GridPtrVec grids;
    bool stats = true;
    if (kind == "multi") {
        /* A vector and an int grid first, then a double level set, then a float grid of
         * unknown class whose inactive -1 must not count (the fog rule applies). */
        vdb::Vec3SGrid::Ptr vel = vdb::Vec3SGrid::create();
        vel->setName("velocity");
        vel->tree().setValueOn(vdb::Coord(0, 0, 0), vdb::Vec3s(1, 0, 0));
        vdb::Int32Grid::Ptr flags = vdb::Int32Grid::create(0);
        flags->setName("flags");
        flags->tree().setValueOn(vdb::Coord(1, 1, 1), 7);
        vdb::DoubleGrid::Ptr dist = vdb::DoubleGrid::create(3.0);
        dist->setName("dist");
        dist->setGridClass(vdb::GRID_LEVEL_SET);
        dist->tree().fill(vdb::CoordBBox(vdb::Coord(0, 0, 0), vdb::Coord(9, 4, 2)), -1.0, true); /* 150 voxels */
        vdb::FloatGrid::Ptr dens = fixture_fog("density", vdb::GRID_UNKNOWN);
        dens->tree().setValueOn(vdb::Coord(1, 2, 3), 1.0f);
        dens->tree().setValueOn(vdb::Coord(4, 5, 6), 2.0f);
        dens->tree().setValueOff(vdb::Coord(7, 8, 9), -1.0f);
        grids = {vel, flags, dist, dens};
    } else if (kind == "vector") {
        vdb::Vec3SGrid::Ptr vel = vdb::Vec3SGrid::create();
        vel->setName("velocity");
        vel->tree().setValueOn(vdb::Coord(0, 0, 0), vdb::Vec3s(1, 0, 0));
        grids = {vel};
    } else if (kind == "tiles") {
        /* A level set whose inside is inactive tiles: an 80^3 box at -40..39 (8-aligned, so
         * fill() stores 8^3 tiles), one positive active voxel punched into it, and one
         * negative active voxel outside it, in a leaf of positive inactive values. */
        vdb::FloatGrid::Ptr ls = vdb::FloatGrid::create(3.0f);
        ls->setName("ls_box");
        ls->setGridClass(vdb::GRID_LEVEL_SET);
        ls->tree().fill(vdb::CoordBBox(vdb::Coord(-40), vdb::Coord(39)), -3.0f, false);
        ls->tree().setValueOn(vdb::Coord(5, 5, 5), 1.0f);
        ls->tree().setValueOn(vdb::Coord(0, 0, 41), -1.0f);
        grids = {ls};
    } else if (kind == "fogtile") {
        /* Fog: an active 16^3 tile region of 0.5, an inactive tile region of 1.0, and in one
         * leaf active 0.25, 0 and -1. */
        vdb::FloatGrid::Ptr fog = fixture_fog("fog", vdb::GRID_FOG_VOLUME);
        fog->tree().fill(vdb::CoordBBox(vdb::Coord(0), vdb::Coord(15)), 0.5f, true);
        fog->tree().fill(vdb::CoordBBox(vdb::Coord(32), vdb::Coord(39)), 1.0f, false);
        fog->tree().setValueOn(vdb::Coord(100, 0, 0), 0.25f);
        fog->tree().setValueOn(vdb::Coord(101, 0, 0), 0.0f);
        fog->tree().setValueOn(vdb::Coord(102, 0, 0), -1.0f);
        grids = {fog};
    } else if (kind == "xform" || kind == "rotated") {
        vdb::FloatGrid::Ptr fog = fixture_fog("fog", vdb::GRID_FOG_VOLUME);
        fog->tree().setValueOn(vdb::Coord(0, 0, 0), 1.0f);
        fog->tree().setValueOn(vdb::Coord(1, 0, 0), 1.0f);
        if (kind == "xform") {
            vdb::math::MapBase::Ptr m(new vdb::math::ScaleTranslateMap(vdb::Vec3d(2, 1, 3), vdb::Vec3d(10, 20.25, -7.5)));
            fog->setTransform(vdb::math::Transform::Ptr(new vdb::math::Transform(m)));
        } else {
            vdb::math::Transform::Ptr xf = vdb::math::Transform::createLinearTransform(1.0);
            xf->postRotate(0.5, vdb::math::Y_AXIS);
            fog->setTransform(xf);
        }
        grids = {fog};
    } else if (kind == "instance" || kind == "stream") {
        vdb::FloatGrid::Ptr a = fixture_fog("a", vdb::GRID_FOG_VOLUME);
        a->tree().fill(vdb::CoordBBox(vdb::Coord(0), vdb::Coord(2)), 1.0f, true); /* 27 voxels */
        vdb::FloatGrid::Ptr b = vdb::gridPtrCast<vdb::FloatGrid>(a->copyGrid());   /* shares the tree */
        b->setName("b");
        grids = {a, b};
    } else if (kind == "empty") {
        grids = {fixture_fog("nothing", vdb::GRID_FOG_VOLUME)};
    } else if (kind == "liar") {
        /* A fog tile of 128^3 active voxels (one tile of an internal node) whose metadata
         * claims the 9047 voxels of oiio_sphere.vdb: written with the writer's statistics
         * off, so the claim stays. */
        vdb::FloatGrid::Ptr fog = fixture_fog("density", vdb::GRID_FOG_VOLUME);
        fog->tree().fill(vdb::CoordBBox(vdb::Coord(0), vdb::Coord(127)), 0.5f, true);
        fog->insertMeta(vdb::GridBase::META_FILE_VOXEL_COUNT, vdb::Int64Metadata(9047));
        fog->insertMeta(vdb::GridBase::META_FILE_BBOX_MIN, vdb::Vec3IMetadata(vdb::Vec3i(-12, -12, -12)));
        fog->insertMeta(vdb::GridBase::META_FILE_BBOX_MAX, vdb::Vec3IMetadata(vdb::Vec3i(12, 12, 12)));
        grids = {fog};
        stats = false;
    } else if (kind == "deep") {
        /* A level set whose inside is a 1024 x 1152 x 1024 box of inactive -3 tiles (128^3
         * each): 1,207,959,552 solid voxels, more than the default 2^30, in whole chunks. One
         * active voxel of +1 outside it keeps the statistics honest and small. */
        vdb::FloatGrid::Ptr ls = vdb::FloatGrid::create(3.0f);
        ls->setName("slab");
        ls->setGridClass(vdb::GRID_LEVEL_SET);
        ls->tree().fill(vdb::CoordBBox(vdb::Coord(0), vdb::Coord(1023, 1151, 1023)), -3.0f, false);
        ls->tree().setValueOn(vdb::Coord(-1, 0, 0), 1.0f);
        grids = {ls};
    } else if (kind == "scatter") {
        /* Fog: one active voxel at every (16i, 16j, 16k), i, j, k in 0..15: 4096 voxels,
         * each alone in its 16^3 chunk, so 4096 chunks must be dense (16 MiB). */
        vdb::FloatGrid::Ptr fog = fixture_fog("dots", vdb::GRID_FOG_VOLUME);
        for (int i = 0; i < 16; i++)
            for (int j = 0; j < 16; j++)
                for (int k = 0; k < 16; k++)
                    fog->tree().setValueOn(vdb::Coord(16 * i, 16 * j, 16 * k), 1.0f);
        grids = {fog};
    } else {
        throw std::runtime_error("unknown fixture '" + kind + "'");
    }
    if (kind == "stream") {
        /* io::Stream writes no grid offsets: the reader must go straight through. */
        std::ofstream os(path, std::ios::binary);
        vdb::io::Stream(os).write(grids);
        if (!os)
            throw std::runtime_error(std::string("cannot write ") + path);
        return;
    }
    vdb::io::File file(path);
    file.setGridStatsMetadataEnabled(stats);
    file.write(grids);
    file.close();
}

/* The second reading (see vdb_fixtures.h). */
template <class GridT>
void compare(const GridT &grid, double threshold, const vw_world *world, uint64_t *solid, uint64_t *mismatches)
{
    const bool level_set = grid.getGridClass() == vdb::GRID_LEVEL_SET;
    auto acc = grid.getConstAccessor();
    vdb::CoordBBox box = grid.evalActiveVoxelBoundingBox();
    box.expand(2);
    *solid = *mismatches = 0;
    for (int x = box.min().x(); x <= box.max().x(); x++)
        for (int y = box.min().y(); y <= box.max().y(); y++)
            for (int z = box.min().z(); z <= box.max().z(); z++) {
                const vdb::Coord c(x, y, z);
                const double v = (double)acc.getValue(c);
                const bool s = level_set ? v < 0 : (acc.isValueOn(c) && v > threshold);
                if (s && (x == box.min().x() || x == box.max().x() || y == box.min().y() || y == box.max().y() ||
                          z == box.min().z() || z == box.max().z()))
                    throw std::runtime_error("solid voxel on the probe box's face: the probe box is too small");
                *solid += s;
                *mismatches += s != (vw_world_get(world, x, y, z) != 0);
            }
}

} // namespace

extern "C" int vt_vdb_write_fixture(const char *path, const char *kind)
{
    try {
        vdb::initialize();
        write_fixture(path, kind);
        return 0;
    } catch (const std::exception &e) {
        fprintf(stderr, "vt_vdb_write_fixture(%s, %s): %s\n", path, kind, e.what());
    } catch (...) {
        fprintf(stderr, "vt_vdb_write_fixture(%s, %s): unknown exception\n", path, kind);
    }
    return 1;
}

extern "C" int vt_vdb_compare(const char *path, const char *grid_name, float fog_threshold, const vw_world *world,
                              uint64_t *out_solid, uint64_t *out_mismatches)
{
    try {
        vdb::initialize();
        vdb::io::File file(path);
        file.open(/*delayLoad=*/false);
        vdb::GridPtrVecPtr grids = file.getGrids();
        file.close();
        /* NULL: the first float or double grid, the importer's default for the files the
         * tests use (each holds one such grid). */
        for (const vdb::GridBase::Ptr &g : *grids) {
            if (grid_name && g->getName() != grid_name)
                continue;
            if (vdb::FloatGrid::Ptr f = vdb::gridPtrCast<vdb::FloatGrid>(g)) {
                compare(*f, fog_threshold, world, out_solid, out_mismatches);
                return 0;
            }
            if (vdb::DoubleGrid::Ptr d = vdb::gridPtrCast<vdb::DoubleGrid>(g)) {
                compare(*d, fog_threshold, world, out_solid, out_mismatches);
                return 0;
            }
        }
        fprintf(stderr, "vt_vdb_compare(%s): no float grid '%s'\n", path, grid_name ? grid_name : "(first)");
    } catch (const std::exception &e) {
        fprintf(stderr, "vt_vdb_compare(%s): %s\n", path, e.what());
    } catch (...) {
        fprintf(stderr, "vt_vdb_compare(%s): unknown exception\n", path);
    }
    return 1;
}
