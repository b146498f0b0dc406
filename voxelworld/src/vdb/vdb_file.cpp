/*
 * vdb_file.cpp — opening a .vdb without trusting it (see vdb_file.h): the file checks, the
 * stream over the descriptor, and the length checks that run before OpenVDB allocates.
 *
 * The layouts walked here are OpenVDB 10's (openvdb/io/Archive.cc readHeader, readGrid;
 * openvdb/Metadata.cc MetaMap::readMeta; openvdb/io/GridDescriptor.cc read;
 * openvdb/io/DelayedLoadMetadata.cc readValue; openvdb/math/Transform.cc read).
 */
#include "vdb_file.h"

#include <openvdb/openvdb.h>
#include <openvdb/io/DelayedLoadMetadata.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <cstring>

namespace vwvdb {

void fail(vw_status status, const char *fmt, ...)
{
    char buf[400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    throw ShimError{status, buf};
}

namespace {

/* Reads up to n bytes at `at`; fewer only at the end of the file. -1 on an I/O error. */
int64_t pread_full(int fd, void *dst, size_t n, int64_t at)
{
    size_t got = 0;
    while (got < n) {
        const ssize_t r = pread(fd, (char *)dst + got, n - got, (off_t)(at + (int64_t)got));
        if (r < 0 && errno == EINTR)
            continue;
        if (r < 0)
            return -1;
        if (r == 0)
            break;
        got += (size_t)r;
    }
    return (int64_t)got;
}

const char *file_kind(mode_t m)
{
    if (S_ISDIR(m))
        return "a directory";
    if (S_ISFIFO(m))
        return "a FIFO";
    if (S_ISCHR(m))
        return "a character device";
    if (S_ISBLK(m))
        return "a block device";
    if (S_ISSOCK(m))
        return "a socket";
    return "not a plain file";
}

} // namespace

/* ---- the stream --------------------------------------------------------------------- */

FdBuf::int_type FdBuf::underflow()
{
    if (gptr() < egptr())
        return traits_type::to_int_type(*gptr());
    start_ = pos();
    const int64_t n = pread_full(fd_, buf_.data(), buf_.size(), start_);
    setg(buf_.data(), buf_.data(), buf_.data() + std::max<int64_t>(n, 0));
    return n > 0 ? traits_type::to_int_type(*gptr()) : traits_type::eof();
}

std::streamsize FdBuf::xsgetn(char *s, std::streamsize n)
{
    std::streamsize got = 0;
    while (got < n) {
        if (gptr() == egptr()) {
            if (n - got >= (std::streamsize)buf_.size()) {
                /* A large read goes straight to the caller. */
                const int64_t at = pos();
                const int64_t r = pread_full(fd_, s + got, (size_t)(n - got), at);
                if (r <= 0)
                    break;
                got += r;
                start_ = at + r;
                setg(buf_.data(), buf_.data(), buf_.data());
                continue;
            }
            if (traits_type::eq_int_type(underflow(), traits_type::eof()))
                break;
        }
        const std::streamsize k = std::min<std::streamsize>(egptr() - gptr(), n - got);
        memcpy(s + got, gptr(), (size_t)k);
        gbump((int)k);
        got += k;
    }
    return got;
}

FdBuf::pos_type FdBuf::seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode which)
{
    if (!(which & std::ios_base::in))
        return pos_type(off_type(-1));
    const int64_t base = dir == std::ios_base::beg ? 0 : dir == std::ios_base::cur ? pos() : size_;
    const int64_t to = base + (int64_t)off;
    if (to < 0)
        return pos_type(off_type(-1));
    if (to >= start_ && to <= start_ + (egptr() - eback())) {
        setg(eback(), eback() + (to - start_), egptr()); /* within the buffer (tellg lands here) */
    } else {
        start_ = to;
        setg(buf_.data(), buf_.data(), buf_.data());
    }
    return pos_type(off_type(to));
}

FdBuf::pos_type FdBuf::seekpos(pos_type p, std::ios_base::openmode which)
{
    return seekoff(off_type(p), std::ios_base::beg, which);
}

/* ---- the file ----------------------------------------------------------------------- */

VdbFile::VdbFile(const char *path) : is_(&buf_)
{
    /* O_NONBLOCK: opening a FIFO for reading would otherwise wait for a writer. */
    fd_ = open(path, O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
    if (fd_ < 0)
        fail(VW_ERROR_IO, "cannot open: %s", strerror(errno));
    struct stat st;
    if (fstat(fd_, &st) != 0) {
        const int e = errno;
        close(fd_);
        fail(VW_ERROR_IO, "cannot stat: %s", strerror(e));
    }
    if (!S_ISREG(st.st_mode)) {
        close(fd_);
        fail(VW_ERROR_IO, "not a regular file (%s)", file_kind(st.st_mode));
    }
    size_ = (int64_t)st.st_size;
    /* The header: magic (8), format version (4), library version (8), the offsets flag (1)
     * and the UUID (36) for any file written since format 218; 8 is the least to look at. */
    if (size_ < 8) {
        close(fd_);
        fail(VW_ERROR_FORMAT, "not a VDB file: %lld bytes, too short for the header", (long long)size_);
    }
    buf_.attach(fd_, size_);
    /* A short read must stop us rather than leave OpenVDB parsing zeros. */
    is_.exceptions(std::ios::failbit | std::ios::badbit);
}

VdbFile::~VdbFile()
{
    if (fd_ >= 0)
        close(fd_);
}

int64_t VdbFile::span(int64_t at, uint64_t n, int64_t end, const char *what, const char *field) const
{
    if (at > end || n > (uint64_t)(end - at))
        fail(VW_ERROR_FORMAT, "%s: %s at byte %lld claims %llu bytes, but only %lld remain", what, field,
             (long long)at, (unsigned long long)n, (long long)std::max<int64_t>(end - at, 0));
    return at + (int64_t)n;
}

uint32_t VdbFile::u32(int64_t at, int64_t end, const char *what, const char *field) const
{
    if (at > end || end - at < 4)
        fail(VW_ERROR_FORMAT, "truncated VDB file: %s: %s at byte %lld runs past byte %lld", what, field,
             (long long)at, (long long)end);
    unsigned char b[4];
    const int64_t r = pread_full(fd_, b, 4, at);
    if (r != 4)
        fail(r < 0 ? VW_ERROR_IO : VW_ERROR_FORMAT, "%s: cannot read %s at byte %lld", what, field, (long long)at);
    return (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
}

int64_t VdbFile::string(int64_t at, int64_t end, const char *what, const char *field, std::string *text) const
{
    const uint32_t n = u32(at, end, what, field);
    const int64_t body = at + 4;
    if ((int64_t)n > end - body)
        fail(VW_ERROR_FORMAT, "%s: %s at byte %lld claims %u bytes, but only %lld remain", what, field, (long long)at,
             (unsigned)n, (long long)std::max<int64_t>(end - body, 0));
    const int64_t next = body + n;
    if (text) {
        /* Enough to compare with a registered type name; longer names are not registered. */
        char b[64];
        const size_t k = std::min<size_t>(n, sizeof b);
        if (pread_full(fd_, b, k, body) != (int64_t)k)
            fail(VW_ERROR_IO, "%s: cannot read %s at byte %lld", what, field, (long long)body);
        text->assign(b, k);
        if (n > sizeof b)
            text->append("...");
    }
    return next;
}

int64_t VdbFile::check_metamap(int64_t at, int64_t end, int64_t grid_bytes, const char *what) const
{
    namespace vdb = openvdb;
    const uint32_t count = u32(at, end, what, "the metadata count");
    at += 4;
    /* Every entry takes at least 12 bytes, so a huge count runs out of bytes soon. */
    for (uint32_t i = 0; i < count; i++) {
        std::string type;
        at = string(at, end, what, "a metadata name", nullptr);
        at = string(at, end, what, "a metadata type name", &type);
        const uint32_t n = u32(at, end, what, "a metadata value size");
        at += 4;
        if (!vdb::Metadata::isRegisteredType(type) || type == vdb::StringMetadata::staticTypeName()) {
            /* UnknownMetadata and StringMetadata read n bytes. */
            at = span(at, n, end, what, "a metadata value");
        } else if (type == vdb::io::DelayedLoadMetadata::staticTypeName()) {
            if (n == 0)
                continue;
            /* A mask byte and a compressed size per leaf, each block either blosc-compressed
             * (its size first) or raw; a leaf takes at least its 64-byte mask on disk. */
            const int64_t start = at;
            const uint32_t leaves = u32(at, end, what, "the delayed-load leaf count");
            if ((int64_t)leaves > grid_bytes / 64 + 1)
                fail(VW_ERROR_FORMAT, "%s: delayed-load metadata for %u leaves in a grid of %lld bytes", what,
                     (unsigned)leaves, (long long)grid_bytes);
            at += 4;
            for (int block = 0; block < 2; block++) {
                const uint64_t raw = (uint64_t)leaves * (block == 0 ? 1u : 8u);
                const uint32_t packed = u32(at, end, what, "a delayed-load block size");
                at += 4;
                if (block == 1 && packed == UINT32_MAX)
                    break; /* no compressed sizes stored */
                if (packed == 0) {
                    at = span(at, raw, end, what, "a delayed-load block");
                    continue;
                }
                /* Blosc's header holds the uncompressed size at bytes 4..7; OpenVDB reserves
                 * that much before decompressing. */
                if (packed < 16)
                    fail(VW_ERROR_FORMAT, "%s: a delayed-load block of %u bytes, too short for its header", what,
                         (unsigned)packed);
                if (u32(at + 4, end, what, "a delayed-load block's size") > raw + 64)
                    fail(VW_ERROR_FORMAT, "%s: a delayed-load block at byte %lld unpacks to more than %llu bytes",
                         what, (long long)at, (unsigned long long)raw);
                at = span(at, packed, end, what, "a delayed-load block");
            }
            if (at - start < (int64_t)n)
                at = span(start, n, end, what, "a metadata value");
        } else {
            /* TypedMetadata<T> reads sizeof(T), whatever n says. */
            at = span(at, vdb::Metadata::createMetadata(type)->size(), end, what, "a metadata value");
        }
    }
    return at;
}

int64_t VdbFile::check_descriptor(int64_t at, int64_t end, uint32_t file_version, const char *what) const
{
    at = string(at, end, what, "the grid name", nullptr);
    at = string(at, end, what, "the grid type", nullptr);
    if (file_version >= openvdb::OPENVDB_FILE_VERSION_GRID_INSTANCING)
        at = string(at, end, what, "the instance parent's name", nullptr);
    return span(at, 3 * sizeof(int64_t), end, what, "the grid offsets");
}

int64_t VdbFile::check_grid_head(int64_t at, int64_t end, uint32_t file_version, const char *what) const
{
    const int64_t grid_bytes = end - at;
    if (file_version >= openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION)
        at = span(at, 4, end, what, "the compression flags");
    at = check_metamap(at, end, grid_bytes, what);
    /* Before format 216 the transform follows the tree; its type name is read there. */
    if (file_version >= openvdb::OPENVDB_FILE_VERSION_GRID_INSTANCING)
        at = string(at, end, what, "the transform type", nullptr);
    return at;
}

} // namespace vwvdb
