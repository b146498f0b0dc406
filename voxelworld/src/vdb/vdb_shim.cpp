/*
 * vdb_shim.cpp — the OpenVDB (.vdb) importer: the only C++ in libvis, behind the C entry
 * points vw_vdb_load_file and vw_vdb_describe_file of vw.h. Every exception stops at those
 * entry points and becomes a vw_status with a message (STYLE.md: C++ stays in its box).
 *
 * What is solid (OpenVDB's grid classes, openvdb/Types.h GridClass):
 *  - Level sets (GRID_LEVEL_SET) are narrow-band signed distance fields, negative inside.
 *    Beyond the band the values are inactive and hold +background outside and -background
 *    inside: that is what tools::signedFloodFill leaves ("setting outside values to
 *    +background and inside values to -background", openvdb/tools/SignedFloodFill.h,
 *    https://www.openvdb.org/documentation/doxygen/SignedFloodFill_8h.html). So the interior
 *    is every value below zero whatever its active state: band voxels, inactive leaf voxels
 *    and the inactive tiles that fill the deep inside.
 *  - Fog volumes (GRID_FOG_VOLUME) hold densities in [0, 1] on active values; the background
 *    and every inactive value are 0 (the checks of tools::CheckFogVolume,
 *    openvdb/tools/Diagnostics.h). Only active values carry the shape, so a voxel is solid
 *    where the ACTIVE value exceeds the threshold. Grids of unknown (and staggered) class
 *    follow the fog rule: it never makes solid what the file marked inactive.
 *
 * Reading. io::File reads a truncated file without complaint (short reads leave zeros or
 * stale values and the grid simply comes out smaller), and io::Stream over a stream that
 * throws on a short read does notice, but OpenVDB's InternalNode::readTopology is not
 * exception-safe and leaks the nodes it has read. So VdbArchive reads the way io::File::open
 * does, on an ifstream that throws on any short read, and before it touches a grid's tree
 * it checks the grid's end offset (from its descriptor) against the file size: a truncated
 * file is rejected before OpenVDB parses a node. Files written without offsets (by io::Stream
 * or before file format 212) are read straight through instead.
 *
 * Index space to world voxels: the voxel at index (i, j, k) is world voxel (i, j, k), Y up
 * in both. With use_transform, an axis-aligned linear transform (scale s, translation t per
 * axis) maps the index cell [i-0.5, i+0.5] (OpenVDB's index points are voxel centres) to the
 * world interval (t + s(i-0.5), t + s(i+0.5)], and the world voxel n is solid when the point
 * n lies in the interval of a solid index voxel. At scale 1 that is n = round(t + i) (halves
 * round up); larger scales fill s voxels per index voxel without gaps; smaller ones point-
 * sample. Rotations, shears and frustum transforms are refused.
 *
 * Every solid voxel gets material 1 (opaque, default palette). The world is written through
 * the dense chunk arrays of vw_internal.h, like every loader, so it starts with no dirty
 * chunks.
 */
#include <openvdb/openvdb.h>
#include <openvdb/io/Archive.h>
#include <openvdb/io/File.h>
#include <openvdb/io/GridDescriptor.h>
#include <openvdb/io/Stream.h>
#include <openvdb/io/io.h>

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <new>
#include <string>
#include <vector>

extern "C" {
#include "vw_internal.h"
}

namespace {

namespace vdb = openvdb;

const vw_voxel kMaterial = 1;

/* An error of ours, carried to the C boundary. */
struct ShimError {
    vw_status status;
    std::string message;
};

[[noreturn]] void fail(vw_status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

void fail(vw_status status, const char *fmt, ...)
{
    char buf[400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    throw ShimError{status, buf};
}

/* Writes "path: message" into err. Only snprintf: it runs in the catch handlers, where an
 * allocation that throws (out of memory) would escape into C. */
vw_status report(vw_error *err, vw_status status, const char *path, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

vw_status report(vw_error *err, vw_status status, const char *path, const char *fmt, ...)
{
    if (!err)
        return status;
    int n = snprintf(err->message, sizeof err->message, "%s: ", path ? path : "(null)");
    if (n < 0 || (size_t)n >= sizeof err->message)
        return status;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err->message + n, sizeof err->message - (size_t)n, fmt, ap);
    va_end(ap);
    return status;
}

/* Runs body and turns whatever it throws into a status; `stage` says what was being read,
 * so that a message from deep inside OpenVDB still tells the user where the file broke. */
template <class Body>
vw_status guarded(const char *path, vw_error *err, const std::string &stage, Body &&body)
{
    try {
        body();
        return VW_OK;
    } catch (const ShimError &e) {
        return report(err, e.status, path, "%s", e.message.c_str());
    } catch (const std::bad_alloc &) {
        return report(err, VW_ERROR_OUT_OF_MEMORY, path, "out of memory in %s", stage.c_str());
    } catch (const std::ios_base::failure &) {
        return report(err, VW_ERROR_FORMAT, path,
                      "truncated or unreadable VDB file: a read failed (or ran past the end) in %s", stage.c_str());
    } catch (const vdb::IoError &e) {
        return report(err, VW_ERROR_FORMAT, path, "not a readable VDB file (%s; OpenVDB: %s)", stage.c_str(), e.what());
    } catch (const vdb::LookupError &e) {
        return report(err, VW_ERROR_UNSUPPORTED, path, "%s: %s", stage.c_str(), e.what());
    } catch (const vdb::KeyError &e) {
        return report(err, VW_ERROR_UNSUPPORTED, path, "%s: %s", stage.c_str(), e.what());
    } catch (const vdb::NotImplementedError &e) {
        return report(err, VW_ERROR_UNSUPPORTED, path, "%s: %s", stage.c_str(), e.what());
    } catch (const vdb::Exception &e) {
        return report(err, VW_ERROR_FORMAT, path, "malformed VDB data in %s (OpenVDB: %s)", stage.c_str(), e.what());
    } catch (const std::exception &e) {
        return report(err, VW_ERROR_FORMAT, path, "malformed VDB data in %s (%s)", stage.c_str(), e.what());
    } catch (...) {
        return report(err, VW_ERROR_FORMAT, path, "unknown C++ exception in %s", stage.c_str());
    }
}

const char *class_token(vdb::GridClass c)
{
    switch (c) {
    case vdb::GRID_LEVEL_SET: return "level_set";
    case vdb::GRID_FOG_VOLUME: return "fog_volume";
    case vdb::GRID_STAGGERED: return "staggered";
    default: return "unknown";
    }
}

/* ---- reading ------------------------------------------------------------------------ */

struct GridEntry {
    vdb::io::GridDescriptor gd;
    std::string name;          /* unique name as users see it: "density", or "density[1]"   */
    vdb::GridBase::Ptr full;   /* only for files without offsets, read at open              */
};

/* A read-only archive over one file (see the top of this file for why not io::File). It
 * derives from io::Archive for the protected header, descriptor and grid readers that
 * io::File and io::Stream are built from. */
class VdbArchive : public vdb::io::Archive {
public:
    /* `stage` names what is being read; it belongs to the caller so that it outlives an
     * exception that unwinds this archive. */
    VdbArchive(const char *path, std::string &stage) : stage_(stage)
    {
        struct stat st;
        if (stat(path, &st) != 0)
            fail(VW_ERROR_IO, "cannot open: %s", strerror(errno));
        if (!S_ISREG(st.st_mode))
            fail(VW_ERROR_IO, "not a regular file");
        size_ = (int64_t)st.st_size;
        is_.open(path, std::ios::in | std::ios::binary);
        if (!is_)
            fail(VW_ERROR_IO, "cannot open: %s", strerror(errno));
        /* A short read must stop us rather than leave OpenVDB parsing zeros. */
        is_.exceptions(std::ios::failbit | std::ios::badbit);

        stage_ = "the file header";
        if (size_ < 8)
            fail(VW_ERROR_FORMAT, "not a VDB file: %lld bytes, too short for the header", (long long)size_);
        readHeader(is_);
        meta_ = std::make_shared<vdb::io::StreamMetadata>();
        meta_->setSeekable(true);
        vdb::io::setStreamMetadataPtr(is_, meta_, /*transfer=*/false);
        setFormatVersion(is_);
        setLibraryVersion(is_);
        setDataCompression(is_);

        stage_ = "the file metadata";
        vdb::MetaMap file_meta;
        file_meta.readMeta(is_);

        stage_ = "the grid count";
        const int32_t count = readGridCount(is_);
        if (count < 0)
            fail(VW_ERROR_FORMAT, "negative grid count %d", (int)count);

        for (int32_t i = 0; i < count; i++) {
            stage_ = "grid descriptor " + std::to_string(i + 1) + " of " + std::to_string(count);
            GridEntry e;
            const int64_t at = (int64_t)is_.tellg();
            vdb::GridBase::Ptr grid = e.gd.read(is_);
            e.name = vdb::io::GridDescriptor::nameAsString(e.gd.uniqueName());
            if (inputHasGridOffsets()) {
                const vdb::io::GridDescriptor &d = e.gd;
                if (d.getGridPos() < at || d.getEndPos() < d.getGridPos())
                    fail(VW_ERROR_FORMAT, "grid '%s': descriptor offsets %lld..%lld are out of order",
                         e.name.c_str(), (long long)d.getGridPos(), (long long)d.getEndPos());
                if (d.getEndPos() > size_)
                    fail(VW_ERROR_FORMAT, "truncated VDB file: grid '%s' ends at byte %lld but the file has %lld bytes",
                         e.name.c_str(), (long long)d.getEndPos(), (long long)size_);
                is_.seekg(d.getEndPos());
            } else {
                /* No offsets: the only way to the next descriptor is through this grid. */
                stage_ = "grid '" + e.name + "'";
                readGrid(grid, e.gd, is_);
                e.full = grid;
            }
            entries_.push_back(std::move(e));
        }
        if (!inputHasGridOffsets())
            for (GridEntry &e : entries_)
                if (e.gd.isInstance())
                    e.full->setTree(full_grid(parent_of(e))->baseTreePtr());
    }

    const std::vector<GridEntry> &entries() const { return entries_; }

    /* The grid's metadata and class, without its tree. */
    vdb::GridBase::Ptr meta_grid(size_t i)
    {
        const GridEntry &e = entries_[i];
        if (e.full)
            return e.full;
        stage_ = "the metadata of grid '" + e.name + "'";
        vdb::GridBase::Ptr grid = vdb::GridBase::createGrid(e.gd.gridType());
        e.gd.seekToGrid(is_);
        readGridCompression(is_);
        grid->readMeta(is_);
        return grid;
    }

    /* The whole grid (an instance gets its parent's tree). */
    vdb::GridBase::Ptr full_grid(size_t i, int depth = 0)
    {
        const GridEntry &e = entries_[i];
        if (e.full)
            return e.full;
        if (depth > (int)entries_.size())
            fail(VW_ERROR_FORMAT, "grid '%s': instance parents form a cycle", e.name.c_str());
        stage_ = "grid '" + e.name + "'";
        vdb::GridBase::Ptr grid = vdb::GridBase::createGrid(e.gd.gridType());
        grid->setSaveFloatAsHalf(e.gd.saveFloatAsHalf());
        e.gd.seekToGrid(is_);
        readGrid(grid, e.gd, is_);
        if (e.gd.isInstance())
            grid->setTree(full_grid(parent_of(e), depth + 1)->baseTreePtr());
        return grid;
    }

private:
    size_t parent_of(const GridEntry &e) const
    {
        for (size_t j = 0; j < entries_.size(); j++)
            if (entries_[j].gd.uniqueName() == e.gd.instanceParentName())
                return j;
        fail(VW_ERROR_FORMAT, "grid '%s' is an instance of a grid the file does not hold", e.name.c_str());
    }

    std::string &stage_;
    std::ifstream is_;
    int64_t size_ = 0;
    vdb::io::StreamMetadata::Ptr meta_;
    std::vector<GridEntry> entries_;
};

/* ---- index space to world voxels ---------------------------------------------------- */

/* Where an index box lands in the world (see the top of this file). */
class IndexToWorld {
public:
    IndexToWorld(const vdb::math::Transform &xf, bool use_transform)
    {
        identity_ = !use_transform;
        if (identity_)
            return;
        if (!xf.isLinear())
            fail(VW_ERROR_UNSUPPORTED, "the grid's transform is not linear (a frustum); load it with use_transform = 0");
        const vdb::math::Mat4d m = xf.baseMap()->getAffineMap()->getMat4();
        /* OpenVDB multiplies row vectors: world = (i, j, k, 1) * m, translation in row 3. */
        for (int c = 0; c < 3; c++) {
            scale_[c] = m(c, c);
            offset_[c] = m(3, c);
            if (!(std::fabs(scale_[c]) > 0) || !std::isfinite(scale_[c]) || !std::isfinite(offset_[c]))
                fail(VW_ERROR_UNSUPPORTED, "the grid's transform has scale %g on axis %c", scale_[c], "xyz"[c]);
            for (int r = 0; r < 3; r++)
                if (r != c && std::fabs(m(r, c)) > 1e-9 * std::fabs(m(c, c)))
                    fail(VW_ERROR_UNSUPPORTED,
                         "the grid's transform rotates or shears (only scale and translation map onto voxels); "
                         "load it with use_transform = 0");
        }
    }

    /* World box [min, max) of the index box; false when it covers no world voxel. */
    bool map(const vdb::CoordBBox &b, int64_t min[3], int64_t max[3]) const
    {
        for (int a = 0; a < 3; a++) {
            if (identity_) {
                min[a] = b.min()[a];
                max[a] = (int64_t)b.max()[a] + 1;
                continue;
            }
            double e0 = offset_[a] + scale_[a] * ((double)b.min()[a] - 0.5);
            double e1 = offset_[a] + scale_[a] * ((double)b.max()[a] + 0.5);
            if (e0 > e1)
                std::swap(e0, e1);
            /* Voxels n with e0 < n <= e1. */
            const double f0 = std::floor(e0) + 1.0, f1 = std::floor(e1) + 1.0;
            const double limit = 4611686018427387904.0; /* 2^62: world_create refuses far sooner */
            if (!(std::fabs(f0) < limit) || !(std::fabs(f1) < limit))
                fail(VW_ERROR_RANGE, "the transform puts voxels beyond +-2^62");
            min[a] = (int64_t)f0;
            max[a] = (int64_t)f1;
            if (max[a] <= min[a])
                return false;
        }
        return true;
    }

private:
    bool identity_ = true;
    double scale_[3] = {1, 1, 1}, offset_[3] = {0, 0, 0};
};

/* ---- the solid set ------------------------------------------------------------------ */

/* Calls emit(CoordBBox) for boxes of solid index voxels covering the solid set exactly:
 * one per solid tile, one per run of solid voxels along x in a leaf. */
template <class TreeT, class Emit>
void visit_solid(const TreeT &tree, bool level_set, double threshold, Emit &&emit)
{
    using ValueT = typename TreeT::ValueType;
    using LeafT = typename TreeT::LeafNodeType;
    /* Tiles of the root and internal nodes; the leaves come next, run by run. */
    typename TreeT::ValueAllCIter it = tree.cbeginValueAll();
    it.setMaxDepth(TreeT::ValueAllCIter::LEAF_DEPTH - 1);
    for (; it; ++it) {
        const double v = (double)*it;
        if (level_set ? v < 0 : (it.isValueOn() && v > threshold)) {
            vdb::CoordBBox b;
            if (it.getBoundingBox(b))
                emit(b);
        }
    }
    const int dim = (int)LeafT::DIM;
    for (auto leaf = tree.cbeginLeaf(); leaf; ++leaf) {
        const vdb::Coord o = leaf->origin();
        for (int z = 0; z < dim; z++)
            for (int y = 0; y < dim; y++) {
                int x = 0;
                while (x < dim) {
                    auto solid = [&](int xx) {
                        const vdb::Index n = LeafT::coordToOffset(vdb::Coord(xx, y, z));
                        const ValueT v = leaf->getValue(n);
                        return level_set ? (double)v < 0 : (leaf->isValueOn(n) && (double)v > threshold);
                    };
                    while (x < dim && !solid(x))
                        x++;
                    const int x0 = x;
                    while (x < dim && solid(x))
                        x++;
                    if (x > x0)
                        emit(vdb::CoordBBox(o.offsetBy(x0, y, z), o.offsetBy(x - 1, y, z)));
                }
            }
    }
}

/* Writes boxes of material into a world's dense chunk arrays; settle() recounts the
 * chunks touched (vw_internal.h: the loader path, which marks nothing dirty). */
class WorldWriter {
public:
    explicit WorldWriter(vw_world *w) : w_(w) {}

    void box(const int64_t min[3], const int64_t max[3])
    {
        const int s = w_->chunk_shift, cs = w_->chunk_size;
        int32_t lo[3], hi[3], c0[3], c1[3];
        for (int a = 0; a < 3; a++) {
            /* The world was sized to hold every box: these are in range. */
            lo[a] = (int32_t)(min[a] - w_->origin[a]);
            hi[a] = (int32_t)(max[a] - w_->origin[a]);
            c0[a] = lo[a] >> s;
            c1[a] = (hi[a] - 1) >> s;
        }
        for (int32_t cz = c0[2]; cz <= c1[2]; cz++)
            for (int32_t cy = c0[1]; cy <= c1[1]; cy++)
                for (int32_t cx = c0[0]; cx <= c1[0]; cx++) {
                    const int32_t cc[3] = {cx, cy, cz};
                    int32_t l0[3], l1[3];
                    bool whole = true;
                    for (int a = 0; a < 3; a++) {
                        const int32_t base = cc[a] << s;
                        l0[a] = std::max(lo[a] - base, 0);
                        l1[a] = std::min(hi[a] - base, cs);
                        whole = whole && l0[a] == 0 && l1[a] == cs;
                    }
                    const uint32_t index = vwi_index(w_, cx, cy, cz);
                    const vwi_chunk &c = w_->chunk[index];
                    if (!c.voxels && c.uniform == kMaterial)
                        continue;
                    if (whole) {
                        vwi_chunk_set_uniform(w_, index, kMaterial);
                        continue;
                    }
                    /* The world is new, so every dense chunk is one this writer made: noting
                     * each as it turns dense lists every chunk to settle (a chunk listed
                     * twice, after a whole-chunk fill in between, settles harmlessly). */
                    if (!c.voxels)
                        dense_.push_back(index);
                    uint8_t *v = vwi_chunk_dense(w_, index);
                    if (!v)
                        throw std::bad_alloc();
                    for (int32_t z = l0[2]; z < l1[2]; z++)
                        for (int32_t y = l0[1]; y < l1[1]; y++)
                            memset(v + l0[0] + ((y + (z << s)) << s), kMaterial, (size_t)(l1[0] - l0[0]));
                }
    }

    void settle()
    {
        for (uint32_t index : dense_)
            vwi_chunk_settle(w_, index);
        dense_.clear();
    }

private:
    vw_world *w_;
    std::vector<uint32_t> dense_;
};

struct WorldDeleter {
    void operator()(vw_world *w) const { vw_world_destroy(w); }
};
using WorldPtr = std::unique_ptr<vw_world, WorldDeleter>;

int64_t floor_to(int64_t v, int64_t m)
{
    const int64_t q = v / m;
    return (q * m > v ? q - 1 : q) * m;
}

template <class GridT>
WorldPtr grid_to_world(const GridT &grid, const vw_vdb_options &opt, int32_t chunk_size)
{
    const bool level_set = grid.getGridClass() == vdb::GRID_LEVEL_SET;
    const IndexToWorld map(grid.transform(), opt.use_transform != 0);
    const double threshold = (double)opt.fog_threshold;

    /* Pass 1: the bounding box of the solid world voxels. */
    int64_t bmin[3], bmax[3];
    bool any = false;
    visit_solid(grid.tree(), level_set, threshold, [&](const vdb::CoordBBox &b) {
        int64_t mn[3], mx[3];
        if (!map.map(b, mn, mx))
            return;
        for (int a = 0; a < 3; a++) {
            bmin[a] = any ? std::min(bmin[a], mn[a]) : mn[a];
            bmax[a] = any ? std::max(bmax[a], mx[a]) : mx[a];
        }
        any = true;
    });

    /* The smallest box of whole chunks around them (one chunk at the origin when none). */
    vw_world_desc desc;
    memset(&desc, 0, sizeof desc);
    desc.chunk_size = chunk_size;
    for (int a = 0; a < 3; a++) {
        if (!any) {
            desc.size[a] = chunk_size;
            continue;
        }
        desc.origin[a] = floor_to(bmin[a], chunk_size);
        const int64_t end = floor_to(bmax[a] + chunk_size - 1, chunk_size);
        if (end - desc.origin[a] > VWI_MAX_AXIS)
            fail(VW_ERROR_RANGE, "the solid voxels span %lld voxels along %c (%lld..%lld); a world holds at most %d",
                 (long long)(bmax[a] - bmin[a]), "xyz"[a], (long long)bmin[a], (long long)(bmax[a] - 1), VWI_MAX_AXIS);
        desc.size[a] = (int32_t)(end - desc.origin[a]);
    }
    vw_world *raw = nullptr;
    vw_error werr = {{0}};
    vw_status st = vw_world_create(&desc, &raw, &werr);
    if (st != VW_OK)
        fail(st, "%s", werr.message);
    WorldPtr world(raw);

    /* Pass 2: write them. */
    if (any) {
        WorldWriter out(world.get());
        visit_solid(grid.tree(), level_set, threshold, [&](const vdb::CoordBBox &b) {
            int64_t mn[3], mx[3];
            if (map.map(b, mn, mx))
                out.box(mn, mx);
        });
        out.settle();
    }
    return world;
}

std::string grid_list(VdbArchive &archive)
{
    std::string s;
    for (const GridEntry &e : archive.entries()) {
        if (!s.empty())
            s += ", ";
        s += "'" + e.name + "'";
    }
    return s.empty() ? "none" : s;
}

bool is_float_type(const vdb::GridBase &g) { return g.isType<vdb::FloatGrid>(); }
bool is_double_type(const vdb::GridBase &g) { return g.isType<vdb::DoubleGrid>(); }

void load(const char *path, const vw_vdb_options &opt, int32_t chunk_size, vw_world **out_world, std::string &stage)
{
    vdb::initialize(); /* idempotent: OpenVDB guards its registry itself */
    VdbArchive archive(path, stage);
    stage = "the grid list";

    /* Which grid: by name, else the first float grid, else the first double grid. The empty
     * grid that each descriptor creates tells the type without reading the tree. */
    const std::vector<GridEntry> &entries = archive.entries();
    size_t pick = entries.size();
    if (opt.grid) {
        for (size_t i = 0; i < entries.size() && pick == entries.size(); i++)
            if (entries[i].name == opt.grid || entries[i].gd.gridName() == opt.grid)
                pick = i;
        if (pick == entries.size())
            fail(VW_ERROR_INVALID_ARGUMENT, "no grid named '%s' (the file holds %s)", opt.grid, grid_list(archive).c_str());
    } else {
        for (int want_double = 0; want_double < 2 && pick == entries.size(); want_double++)
            for (size_t i = 0; i < entries.size() && pick == entries.size(); i++) {
                vdb::GridBase::Ptr g = vdb::GridBase::createGrid(entries[i].gd.gridType());
                if (want_double ? is_double_type(*g) : is_float_type(*g))
                    pick = i;
            }
        if (pick == entries.size())
            fail(VW_ERROR_UNSUPPORTED, "no float or double grid to import (the file holds %s)", grid_list(archive).c_str());
    }

    vdb::GridBase::Ptr grid = archive.full_grid(pick);
    stage = "converting grid '" + entries[pick].name + "'";
    WorldPtr world;
    if (vdb::FloatGrid::Ptr f = vdb::gridPtrCast<vdb::FloatGrid>(grid))
        world = grid_to_world(*f, opt, chunk_size);
    else if (vdb::DoubleGrid::Ptr d = vdb::gridPtrCast<vdb::DoubleGrid>(grid))
        world = grid_to_world(*d, opt, chunk_size);
    else
        fail(VW_ERROR_UNSUPPORTED, "grid '%s' holds %s values; only float and double grids can be imported",
             entries[pick].name.c_str(), grid->valueType().c_str());
    *out_world = world.release();
}

/* Appends to a bounded buffer, keeping it NUL-terminated; the tail is cut off. */
class Out {
public:
    Out(char *buf, size_t cap) : buf_(buf), cap_(cap) { buf_[0] = '\0'; }
    void add(const std::string &s)
    {
        const size_t n = std::min(s.size(), cap_ - 1 - len_);
        memcpy(buf_ + len_, s.data(), n);
        len_ += n;
        buf_[len_] = '\0';
    }

private:
    char *buf_;
    size_t cap_, len_ = 0;
};

/* A grid name as one field: bare unless it holds spaces, quotes or control characters. */
std::string name_field(const std::string &name)
{
    bool plain = !name.empty();
    for (unsigned char c : name)
        plain = plain && c > ' ' && c != '"' && c != '\\' && c != 0x7f;
    if (plain)
        return name;
    std::string q = "\"";
    for (unsigned char c : name) {
        if (c == '"' || c == '\\') {
            q += '\\';
            q += (char)c;
        } else if (c < ' ' || c == 0x7f) {
            char hex[8];
            snprintf(hex, sizeof hex, "\\x%02x", c);
            q += hex;
        } else {
            q += (char)c;
        }
    }
    return q + "\"";
}

void describe(const char *path, Out &out, std::string &stage)
{
    vdb::initialize();
    VdbArchive archive(path, stage);
    for (size_t i = 0; i < archive.entries().size(); i++) {
        const GridEntry &e = archive.entries()[i];
        vdb::GridBase::Ptr g = archive.meta_grid(i);
        /* OpenVDB's writer stores the active bbox and count with each grid (addStatsMetadata);
         * a file without them gets them counted from the tree. */
        vdb::CoordBBox bbox;
        vdb::Index64 active = 0;
        auto bmin = g->getMetadata<vdb::Vec3IMetadata>(vdb::GridBase::META_FILE_BBOX_MIN);
        auto bmax = g->getMetadata<vdb::Vec3IMetadata>(vdb::GridBase::META_FILE_BBOX_MAX);
        auto count = g->getMetadata<vdb::Int64Metadata>(vdb::GridBase::META_FILE_VOXEL_COUNT);
        if (bmin && bmax && count) {
            bbox = vdb::CoordBBox(vdb::Coord(bmin->value()), vdb::Coord(bmax->value()));
            active = (vdb::Index64)count->value();
        } else {
            vdb::GridBase::Ptr full = archive.full_grid(i);
            bbox = full->evalActiveVoxelBoundingBox();
            active = full->activeVoxelCount();
            g = full;
        }
        char line[256];
        if (active == 0 || bbox.empty())
            snprintf(line, sizeof line, " %s %s empty %llu\n", g->valueType().c_str(), class_token(g->getGridClass()),
                     (unsigned long long)active);
        else
            snprintf(line, sizeof line, " %s %s (%d,%d,%d)->(%d,%d,%d) %llu\n", g->valueType().c_str(),
                     class_token(g->getGridClass()), bbox.min().x(), bbox.min().y(), bbox.min().z(), bbox.max().x(),
                     bbox.max().y(), bbox.max().z(), (unsigned long long)active);
        out.add(name_field(e.name) + line);
    }
}

} // namespace

extern "C" vw_status vw_vdb_load_file(const char *path, const vw_vdb_options *options, vw_world **out_world,
                                      vw_error *err)
{
    if (!path || !out_world)
        return report(err, VW_ERROR_INVALID_ARGUMENT, path, "vw_vdb_load_file: path and out_world must not be NULL");
    vw_vdb_options opt;
    memset(&opt, 0, sizeof opt);
    if (options)
        opt = *options;
    const int32_t chunk_size = opt.chunk_size ? opt.chunk_size : 16;
    if (chunk_size != 16 && chunk_size != 32)
        return report(err, VW_ERROR_INVALID_ARGUMENT, path, "chunk size %d: must be 0 (16), 16 or 32",
                      (int)opt.chunk_size);
    if (std::isnan(opt.fog_threshold))
        return report(err, VW_ERROR_INVALID_ARGUMENT, path, "fog_threshold is NaN");
    std::string stage = "the file"; /* short enough not to allocate */
    vw_world *world = nullptr;
    const vw_status st = guarded(path, err, stage, [&] { load(path, opt, chunk_size, &world, stage); });
    if (st == VW_OK)
        *out_world = world;
    return st;
}

extern "C" vw_status vw_vdb_describe_file(const char *path, char *out, size_t capacity, vw_error *err)
{
    if (!path || !out || capacity == 0)
        return report(err, VW_ERROR_INVALID_ARGUMENT, path,
                      "vw_vdb_describe_file: path and out must not be NULL, capacity not 0");
    std::string stage = "the file";
    return guarded(path, err, stage, [&] {
        Out text(out, capacity);
        describe(path, text, stage);
    });
}

/* ---- test hooks --------------------------------------------------------------------- */
/* Not part of vw.h: tests/test_vdb.c declares them. They write small .vdb files with the
 * cases the shared data lacks, and check an imported world voxel by voxel against a second
 * reading of the grid. Both return 0 on success. */

extern "C" int vwi_vdb_test_write_fixture(const char *path, const char *kind);
extern "C" int vwi_vdb_test_compare(const char *path, const char *grid_name, float fog_threshold,
                                    const vw_world *world, uint64_t *out_solid, uint64_t *out_mismatches);

namespace {

vdb::FloatGrid::Ptr fixture_fog(const char *name, vdb::GridClass cls)
{
    vdb::FloatGrid::Ptr g = vdb::FloatGrid::create(0.0f);
    g->setName(name);
    g->setGridClass(cls);
    return g;
}

void write_fixture(const char *path, const std::string &kind)
{
    vdb::GridPtrVec grids;
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
    } else {
        fail(VW_ERROR_INVALID_ARGUMENT, "unknown fixture '%s'", kind.c_str());
    }
    if (kind == "stream") {
        /* io::Stream writes no grid offsets: the reader must go straight through. */
        std::ofstream os(path, std::ios::binary);
        vdb::io::Stream(os).write(grids);
        if (!os)
            fail(VW_ERROR_IO, "cannot write %s", path);
        return;
    }
    vdb::io::File file(path);
    file.write(grids);
    file.close();
}

/* A second reading of the solid set: every index voxel of the active bbox (grown by two)
 * probed through a ValueAccessor, by the rules restated, against vw_world_get. */
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
                    fail(VW_ERROR_RANGE, "solid voxel on the probe box's face: the probe box is too small");
                *solid += s;
                *mismatches += s != (vw_world_get(world, x, y, z) != 0);
            }
}

} // namespace

extern "C" int vwi_vdb_test_write_fixture(const char *path, const char *kind)
{
    std::string stage = "writing a fixture";
    return guarded(path, nullptr, stage, [&] {
        vdb::initialize();
        write_fixture(path, kind);
    }) == VW_OK ? 0 : 1;
}

extern "C" int vwi_vdb_test_compare(const char *path, const char *grid_name, float fog_threshold,
                                    const vw_world *world, uint64_t *out_solid, uint64_t *out_mismatches)
{
    std::string stage = "the file";
    return guarded(path, nullptr, stage, [&] {
        vdb::initialize();
        VdbArchive archive(path, stage);
        /* NULL: the first float or double grid, as the importer's default for the files the
         * tests use (each holds one grid). */
        for (size_t i = 0; i < archive.entries().size(); i++) {
            if (grid_name && archive.entries()[i].name != grid_name)
                continue;
            vdb::GridBase::Ptr g = archive.full_grid(i);
            if (vdb::FloatGrid::Ptr f = vdb::gridPtrCast<vdb::FloatGrid>(g))
                return compare(*f, fog_threshold, world, out_solid, out_mismatches);
            if (vdb::DoubleGrid::Ptr d = vdb::gridPtrCast<vdb::DoubleGrid>(g))
                return compare(*d, fog_threshold, world, out_solid, out_mismatches);
        }
        fail(VW_ERROR_INVALID_ARGUMENT, "no float grid '%s'", grid_name ? grid_name : "(first)");
    }) == VW_OK ? 0 : 1;
}
