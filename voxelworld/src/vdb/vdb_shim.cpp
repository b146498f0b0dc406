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
 * does, on a stream that throws on any short read (VdbFile, vdb_file.h, which also checks
 * that the path is a regular file and that no length in the metadata runs past its bytes
 * before OpenVDB allocates it), and before it touches a grid's tree it checks the grid's end
 * offset (from its descriptor) against the file size: a truncated file is rejected before
 * OpenVDB parses a node. Files written without offsets (by io::Stream or before file format
 * 212) are read straight through instead.
 *
 * Not trusting the tree. A grid's tree decides how big the world gets, and a few flipped
 * bytes (a root child's origin, a tile's value or state) can turn a small file into a world
 * of billions of voxels. OpenVDB's writer stores the tree's active voxel count and bounding
 * box with every grid (GridBase::addStatsMetadata: file_voxel_count, file_bbox_min/max), so
 * after reading a tree the shim recounts both and refuses a grid that disagrees with its
 * own metadata. What no metadata vouches for (the interior of a level set) is held to the
 * budget: the first pass over the solid set counts the voxels it would write and the chunks
 * it would make dense, and the world's chunk table follows from its bounding box, all before
 * the world is created (vw_vdb_options.budget; the world keeps max_bytes as its limit).
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
#include <openvdb/io/GridDescriptor.h>
#include <openvdb/io/io.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <unordered_set>
#include <vector>

#include "vdb_file.h"

namespace {

namespace vdb = openvdb;
using vwvdb::fail;
using vwvdb::ShimError;

const vw_voxel kMaterial = 1;

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
     * exception that unwinds this archive. A file without grid offsets is read whole here,
     * so it must fit in `max_bytes`. */
    VdbArchive(const char *path, std::string &stage, uint64_t max_bytes)
        : stage_(stage), file_(path), is_(file_.stream()), size_(file_.size())
    {
        stage_ = "the file header";
        readHeader(is_);
        meta_ = std::make_shared<vdb::io::StreamMetadata>();
        meta_->setSeekable(true);
        vdb::io::setStreamMetadataPtr(is_, meta_, /*transfer=*/false);
        setFormatVersion(is_);
        setLibraryVersion(is_);
        setDataCompression(is_);

        stage_ = "the file metadata";
        file_.check_metamap(is_.tellg(), size_, size_, "the file metadata");
        vdb::MetaMap file_meta;
        file_meta.readMeta(is_);

        stage_ = "the grid count";
        const int32_t count = readGridCount(is_);
        if (count < 0)
            fail(VW_ERROR_FORMAT, "negative grid count %d", (int)count);
        if (!inputHasGridOffsets() && (uint64_t)size_ > max_bytes)
            fail(VW_ERROR_BUDGET,
                 "the file stores no grid offsets, so all its grids are read at once: %lld bytes, more than the "
                 "budget's max_bytes (%llu)",
                 (long long)size_, (unsigned long long)max_bytes);

        for (int32_t i = 0; i < count; i++) {
            stage_ = "grid descriptor " + std::to_string(i + 1) + " of " + std::to_string(count);
            GridEntry e;
            const int64_t at = (int64_t)is_.tellg();
            file_.check_descriptor(at, size_, fileVersion(), stage_.c_str());
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
                file_.check_grid_head(is_.tellg(), size_, fileVersion(), stage_.c_str());
                readGrid(grid, e.gd, is_);
                e.full = grid;
            }
            entries_.push_back(std::move(e));
        }
        if (!inputHasGridOffsets())
            for (GridEntry &e : entries_)
                if (e.gd.isInstance())
                    e.full->setTree(full_grid(parent_of(e), max_bytes)->baseTreePtr());
    }

    const std::vector<GridEntry> &entries() const { return entries_; }

    /* The grid's metadata and class, without its tree. */
    vdb::GridBase::Ptr meta_grid(size_t i)
    {
        const GridEntry &e = entries_[i];
        if (e.full)
            return e.full;
        stage_ = "the metadata of grid '" + e.name + "'";
        file_.check_grid_head(e.gd.getGridPos(), e.gd.getEndPos(), fileVersion(), stage_.c_str());
        vdb::GridBase::Ptr grid = vdb::GridBase::createGrid(e.gd.gridType());
        e.gd.seekToGrid(is_);
        readGridCompression(is_);
        grid->readMeta(is_);
        return grid;
    }

    /* Refuses a tree stored in more than `max_bytes` (an instance's is its parent's): in
     * memory it takes at least as much as on disk (leaves of 8^3 values, internal nodes of
     * 16^3 and 32^3 entries, against their masks and active values in the file). */
    void check_stored_bytes(size_t i, uint64_t max_bytes, int depth = 0) const
    {
        const GridEntry &e = entries_[i];
        if (e.full)
            return; /* read at open, within the file's check */
        if (depth > (int)entries_.size())
            fail(VW_ERROR_FORMAT, "grid '%s': instance parents form a cycle", e.name.c_str());
        if (e.gd.isInstance())
            return check_stored_bytes(parent_of(e), max_bytes, depth + 1);
        const int64_t bytes = e.gd.getEndPos() - e.gd.getGridPos();
        char b1[32], b2[32];
        if ((uint64_t)bytes > max_bytes)
            fail(VW_ERROR_BUDGET, "grid '%s' is stored in %s, more than the budget's max_bytes (%s)", e.name.c_str(),
                 vwi_format_bytes((uint64_t)bytes, b1, sizeof b1), vwi_format_bytes(max_bytes, b2, sizeof b2));
    }

    /* The whole grid (an instance gets its parent's tree), within check_stored_bytes. */
    vdb::GridBase::Ptr full_grid(size_t i, uint64_t max_bytes, int depth = 0)
    {
        const GridEntry &e = entries_[i];
        if (e.full)
            return e.full;
        if (depth > (int)entries_.size())
            fail(VW_ERROR_FORMAT, "grid '%s': instance parents form a cycle", e.name.c_str());
        check_stored_bytes(i, max_bytes);
        stage_ = "grid '" + e.name + "'";
        file_.check_grid_head(e.gd.getGridPos(), e.gd.getEndPos(), fileVersion(), stage_.c_str());
        vdb::GridBase::Ptr grid = vdb::GridBase::createGrid(e.gd.gridType());
        grid->setSaveFloatAsHalf(e.gd.saveFloatAsHalf());
        e.gd.seekToGrid(is_);
        readGrid(grid, e.gd, is_);
        if (e.gd.isInstance())
            grid->setTree(full_grid(parent_of(e), max_bytes, depth + 1)->baseTreePtr());
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
    vwvdb::VdbFile file_;
    std::istream &is_;
    int64_t size_;
    vdb::io::StreamMetadata::Ptr meta_;
    std::vector<GridEntry> entries_;
};

/* ---- what the file says of its own tree --------------------------------------------- */

std::string bbox_text(const vdb::CoordBBox &b)
{
    if (b.empty())
        return "empty";
    char t[96];
    snprintf(t, sizeof t, "(%d,%d,%d)->(%d,%d,%d)", b.min().x(), b.min().y(), b.min().z(), b.max().x(), b.max().y(),
             b.max().z());
    return t;
}

/* Refuses a tree whose active voxel count or bounding box differs from the statistics the
 * writer stored with it (see the top of this file). A grid without them passes. */
void check_against_metadata(const vdb::GridBase &grid, const std::string &name)
{
    auto bmin = grid.getMetadata<vdb::Vec3IMetadata>(vdb::GridBase::META_FILE_BBOX_MIN);
    auto bmax = grid.getMetadata<vdb::Vec3IMetadata>(vdb::GridBase::META_FILE_BBOX_MAX);
    auto count = grid.getMetadata<vdb::Int64Metadata>(vdb::GridBase::META_FILE_VOXEL_COUNT);
    if (!bmin || !bmax || !count)
        return;
    const vdb::Index64 active = grid.activeVoxelCount();
    const vdb::CoordBBox box = grid.evalActiveVoxelBoundingBox();
    const vdb::CoordBBox said(vdb::Coord(bmin->value()), vdb::Coord(bmax->value()));
    const bool same_count = count->value() >= 0 && (vdb::Index64)count->value() == active;
    const bool same_box = active == 0 || (box.min() == said.min() && box.max() == said.max());
    if (!same_count || !same_box)
        fail(VW_ERROR_FORMAT,
             "grid '%s' disagrees with its own metadata: the tree has %llu active voxels in %s, the metadata "
             "(file_voxel_count, file_bbox_min/max) says %lld in %s",
             name.c_str(), (unsigned long long)active, bbox_text(box).c_str(), (long long)count->value(),
             bbox_text(said).c_str());
}

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
                    if (!v) {
                        /* Cost (below) counted this chunk, so the budget holds unless the
                         * estimate is wrong; either way the world refuses, and we say so. */
                        const vw_status st = vwi_dense_failure(w_);
                        char b1[32], b2[32];
                        fail(st, "%s making chunk %u dense (the world holds %s, its limit %s)",
                             st == VW_ERROR_BUDGET ? "over budget" : "out of memory", (unsigned)index,
                             vwi_format_bytes(vwi_world_bytes(w_), b1, sizeof b1),
                             vwi_format_bytes(w_->max_bytes, b2, sizeof b2));
                    }
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

int64_t floor_div(int64_t v, int64_t m)
{
    const int64_t q = v / m;
    return q * m > v ? q - 1 : q;
}

int64_t floor_to(int64_t v, int64_t m) { return floor_div(v, m) * m; }

uint64_t sat_mul(uint64_t a, uint64_t b) { return b && a > UINT64_MAX / b ? UINT64_MAX : a * b; }

/* What the first pass learns before the world exists (see the top of this file): the solid
 * voxels' bounding box, how many voxels the writer will set (an upper bound: boxes that
 * overlap once mapped count twice), and which chunks it will make dense (those that some box
 * covers in part; WorldWriter makes exactly those dense, so no more are at any moment). The
 * dense set is held to the budget as it grows, so its size, and the time spent on it, stay
 * bounded whatever the tree holds. */
class Cost {
public:
    Cost(const std::string &grid, int32_t chunk_size, const vw_budget &budget)
        : grid_(grid), cs_(chunk_size), chunk_bytes_((uint64_t)chunk_size * chunk_size * chunk_size), budget_(budget)
    {
    }

    void add(const int64_t mn[3], const int64_t mx[3])
    {
        uint64_t volume = 1;
        for (int a = 0; a < 3; a++) {
            volume = sat_mul(volume, (uint64_t)(mx[a] - mn[a]));
            bmin[a] = any ? std::min(bmin[a], mn[a]) : mn[a];
            bmax[a] = any ? std::max(bmax[a], mx[a]) : mx[a];
        }
        any = true;
        voxels = volume > UINT64_MAX - voxels ? UINT64_MAX : voxels + volume;

        /* Chunk ranges: c0..c1 touched, f0..f1 covered whole. */
        int64_t c0[3], c1[3], f0[3], f1[3];
        bool some_whole = true;
        for (int a = 0; a < 3; a++) {
            c0[a] = floor_div(mn[a], cs_);
            c1[a] = floor_div(mx[a] - 1, cs_);
            f0[a] = floor_div(mn[a] + cs_ - 1, cs_);
            f1[a] = floor_div(mx[a], cs_) - 1;
            some_whole = some_whole && f0[a] <= f1[a];
        }
        if (!some_whole) {
            slab(c0, c1); /* no chunk is covered whole: every one is partial */
            return;
        }
        /* A chunk is partial where some axis is at an end the box covers in part: slabs. */
        for (int a = 0; a < 3; a++) {
            const int64_t ends[2] = {c0[a] < f0[a] ? c0[a] : INT64_MIN, c1[a] > f1[a] ? c1[a] : INT64_MIN};
            for (int64_t e : ends) {
                if (e == INT64_MIN)
                    continue;
                int64_t lo[3] = {c0[0], c0[1], c0[2]}, hi[3] = {c1[0], c1[1], c1[2]};
                lo[a] = hi[a] = e;
                slab(lo, hi);
            }
        }
    }

    size_t dense() const { return dense_.size(); }

    bool any = false;
    int64_t bmin[3] = {0, 0, 0}, bmax[3] = {0, 0, 0};
    uint64_t voxels = 0;

private:
    using Key = std::array<int64_t, 3>;
    struct KeyHash {
        size_t operator()(const Key &k) const
        {
            uint64_t h = (uint64_t)k[0] * 0x9E3779B97F4A7C15ull;
            h ^= (uint64_t)k[1] + 0x7F4A7C159E3779B9ull + (h << 6) + (h >> 2);
            h ^= (uint64_t)k[2] + 0x94D049BB133111EBull + (h << 6) + (h >> 2);
            return (size_t)h;
        }
    };

    void slab(const int64_t lo[3], const int64_t hi[3])
    {
        for (int64_t z = lo[2]; z <= hi[2]; z++)
            for (int64_t y = lo[1]; y <= hi[1]; y++)
                for (int64_t x = lo[0]; x <= hi[0]; x++)
                    partial(Key{x, y, z});
    }

    void partial(const Key &k)
    {
        /* The runs of one leaf land in the same chunk, one after another. */
        if (has_last_ && k == last_)
            return;
        has_last_ = true;
        last_ = k;
        if (!dense_.insert(k).second)
            return;
        if ((uint64_t)dense_.size() * chunk_bytes_ > budget_.max_bytes) {
            char n[32], b1[32], b2[32];
            fail(VW_ERROR_BUDGET, "grid '%s' would make at least %s chunks dense (%s), more than the budget's max_bytes (%s)",
                 grid_.c_str(), vwi_format_count(dense_.size(), n, sizeof n),
                 vwi_format_bytes((uint64_t)dense_.size() * chunk_bytes_, b1, sizeof b1),
                 vwi_format_bytes(budget_.max_bytes, b2, sizeof b2));
        }
    }

    const std::string &grid_;
    const int64_t cs_;
    const uint64_t chunk_bytes_;
    const vw_budget budget_;
    std::unordered_set<Key, KeyHash> dense_;
    Key last_ = {0, 0, 0};
    bool has_last_ = false;
};

template <class GridT>
WorldPtr grid_to_world(const GridT &grid, const std::string &name, const vw_vdb_options &opt, int32_t chunk_size,
                       const vw_budget &budget)
{
    const bool level_set = grid.getGridClass() == vdb::GRID_LEVEL_SET;
    const IndexToWorld map(grid.transform(), opt.use_transform != 0);
    const double threshold = (double)opt.fog_threshold;

    /* Pass 1: the bounding box of the solid world voxels, and what writing them costs. */
    Cost cost(name, chunk_size, budget);
    visit_solid(grid.tree(), level_set, threshold, [&](const vdb::CoordBBox &b) {
        int64_t mn[3], mx[3];
        if (map.map(b, mn, mx))
            cost.add(mn, mx);
    });
    char n1[32], n2[32], b1[32], b2[32], b3[32];
    if (cost.voxels > budget.max_voxels)
        fail(VW_ERROR_BUDGET, "grid '%s' would write %s solid voxels, more than the budget's max_voxels (%s)",
             name.c_str(), vwi_format_count(cost.voxels, n1, sizeof n1),
             vwi_format_count(budget.max_voxels, n2, sizeof n2));

    /* The smallest box of whole chunks around them (one chunk at the origin when none). */
    vw_world_desc desc;
    memset(&desc, 0, sizeof desc);
    desc.chunk_size = chunk_size;
    desc.max_bytes = budget.max_bytes;
    uint64_t chunks = 1;
    for (int a = 0; a < 3; a++) {
        if (!cost.any) {
            desc.size[a] = chunk_size;
            continue;
        }
        desc.origin[a] = floor_to(cost.bmin[a], chunk_size);
        const int64_t end = floor_to(cost.bmax[a] + chunk_size - 1, chunk_size);
        if (end - desc.origin[a] > VWI_MAX_AXIS)
            fail(VW_ERROR_RANGE, "the solid voxels span %lld voxels along %c (%lld..%lld); a world holds at most %d",
                 (long long)(cost.bmax[a] - cost.bmin[a]), "xyz"[a], (long long)cost.bmin[a],
                 (long long)(cost.bmax[a] - 1), VWI_MAX_AXIS);
        desc.size[a] = (int32_t)(end - desc.origin[a]);
        chunks *= (uint64_t)(desc.size[a] / chunk_size);
    }
    const uint64_t table = vwi_table_bytes(chunks);
    const uint64_t dense = (uint64_t)cost.dense() * chunk_size * chunk_size * chunk_size;
    if (table + dense > budget.max_bytes)
        fail(VW_ERROR_BUDGET,
             "grid '%s' would need a world of %dx%dx%d voxels taking %s (a table of %s chunks, %s, and %s dense "
             "chunks), more than the budget's max_bytes (%s)",
             name.c_str(), (int)desc.size[0], (int)desc.size[1], (int)desc.size[2],
             vwi_format_bytes(table + dense, b1, sizeof b1), vwi_format_count(chunks, n1, sizeof n1),
             vwi_format_bytes(table, b2, sizeof b2), vwi_format_count(cost.dense(), n2, sizeof n2),
             vwi_format_bytes(budget.max_bytes, b3, sizeof b3));

    vw_world *raw = nullptr;
    vw_error werr = {{0}};
    vw_status st = vw_world_create(&desc, &raw, &werr);
    if (st != VW_OK)
        fail(st, "%s", werr.message);
    WorldPtr world(raw);

    /* Pass 2: write them. */
    if (cost.any) {
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
    const vw_budget budget = vwi_budget(&opt.budget);
    VdbArchive archive(path, stage, budget.max_bytes);
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

    const std::string &name = entries[pick].name;
    {
        vdb::GridBase::Ptr g = vdb::GridBase::createGrid(entries[pick].gd.gridType());
        if (!is_float_type(*g) && !is_double_type(*g))
            fail(VW_ERROR_UNSUPPORTED, "grid '%s' holds %s values; only float and double grids can be imported",
                 name.c_str(), g->valueType().c_str());
    }

    /* What the tree costs, as far as it can be known before reading it: the bytes that hold
     * it and the memory its writer measured (file_mem_bytes). */
    char b1[32], b2[32];
    archive.check_stored_bytes(pick, budget.max_bytes);
    vdb::GridBase::Ptr meta = archive.meta_grid(pick);
    if (auto mem = meta->getMetadata<vdb::Int64Metadata>(vdb::GridBase::META_FILE_MEM_BYTES))
        if (mem->value() > 0 && (uint64_t)mem->value() > budget.max_bytes)
            fail(VW_ERROR_BUDGET, "grid '%s' takes %s in memory (its file_mem_bytes), more than the budget's max_bytes (%s)",
                 name.c_str(), vwi_format_bytes((uint64_t)mem->value(), b1, sizeof b1),
                 vwi_format_bytes(budget.max_bytes, b2, sizeof b2));
    vdb::GridBase::Ptr grid = archive.full_grid(pick, budget.max_bytes);

    stage = "checking grid '" + name + "'";
    if (grid->memUsage() > budget.max_bytes)
        fail(VW_ERROR_BUDGET, "grid '%s' takes %s in memory once read, more than the budget's max_bytes (%s)",
             name.c_str(), vwi_format_bytes(grid->memUsage(), b1, sizeof b1),
             vwi_format_bytes(budget.max_bytes, b2, sizeof b2));
    check_against_metadata(*grid, name);

    stage = "converting grid '" + name + "'";
    WorldPtr world;
    if (vdb::FloatGrid::Ptr f = vdb::gridPtrCast<vdb::FloatGrid>(grid))
        world = grid_to_world(*f, name, opt, chunk_size, budget);
    else if (vdb::DoubleGrid::Ptr d = vdb::gridPtrCast<vdb::DoubleGrid>(grid))
        world = grid_to_world(*d, name, opt, chunk_size, budget);
    else
        fail(VW_ERROR_UNSUPPORTED, "grid '%s' holds %s values; only float and double grids can be imported", name.c_str(),
             grid->valueType().c_str());
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
    /* Describing reads trees only for grids without statistics; those are held to the
     * default budget. */
    VdbArchive archive(path, stage, VW_DEFAULT_MAX_BYTES);
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
            vdb::GridBase::Ptr full = archive.full_grid(i, VW_DEFAULT_MAX_BYTES);
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
