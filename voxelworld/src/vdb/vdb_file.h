/*
 * vdb_file.h — opening a .vdb file for OpenVDB's readers without trusting it (internal to
 * voxelworld/src/vdb/, C++ only).
 *
 * VdbFile opens the path once (O_NONBLOCK, so a FIFO cannot block the open), checks with
 * fstat on that same descriptor that it is a regular file of at least a header's size, and
 * serves every later read through the descriptor (a std::istream over pread), so the file
 * checked is the file read.
 *
 * OpenVDB reads a 32-bit length and allocates and fills that many bytes before it reads
 * them (io::readString, StringMetadata, UnknownMetadata, DelayedLoadMetadata): four flipped
 * bytes in a name's length cost 4 GiB of zeroed memory before the short read is noticed.
 * check_metamap, check_descriptor and check_grid_head walk those structures first, the way
 * OpenVDB 10 parses them (MetaMap::readMeta, GridDescriptor::read, Archive::readGrid,
 * Transform::read), reading only fixed-size fields, and refuse any length that runs past
 * the bytes that hold it.
 */
#ifndef VOXELWORLD_VDB_FILE_H
#define VOXELWORLD_VDB_FILE_H

#include <cstdint>
#include <istream>
#include <streambuf>
#include <string>
#include <vector>

extern "C" {
#include "vw_internal.h"
}

namespace vwvdb {

/* An error of ours, carried to the C boundary (vdb_shim.cpp turns it into a vw_status). */
struct ShimError {
    vw_status status;
    std::string message;
};

[[noreturn]] void fail(vw_status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* A read-only, seekable stream buffer over a file descriptor, read with pread. */
class FdBuf : public std::streambuf {
public:
    FdBuf() : buf_(1 << 16) { setg(buf_.data(), buf_.data(), buf_.data()); }
    void attach(int fd, int64_t size)
    {
        fd_ = fd;
        size_ = size;
    }

protected:
    int_type underflow() override;
    std::streamsize xsgetn(char *s, std::streamsize n) override;
    pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode which) override;
    pos_type seekpos(pos_type pos, std::ios_base::openmode which) override;

private:
    int64_t pos() const { return start_ + (gptr() - eback()); }
    int fd_ = -1;
    int64_t size_ = 0;
    int64_t start_ = 0; /* file offset of eback() */
    std::vector<char> buf_; /* on the heap: archives live on callers' stacks */
};

class VdbFile {
public:
    /* Throws ShimError: VW_ERROR_IO (cannot open, not a regular file), VW_ERROR_FORMAT (too
     * short for a header). */
    explicit VdbFile(const char *path);
    ~VdbFile();
    VdbFile(const VdbFile &) = delete;
    VdbFile &operator=(const VdbFile &) = delete;

    /* Throws std::ios_base::failure on any short read. */
    std::istream &stream() { return is_; }
    int64_t size() const { return size_; }

    /* Each checks the structure that starts at `at` and must end by `end`, and returns
     * where it ends; `what` names it in messages. */
    int64_t check_metamap(int64_t at, int64_t end, int64_t grid_bytes, const char *what) const;
    int64_t check_descriptor(int64_t at, int64_t end, uint32_t file_version, const char *what) const;
    /* A grid's head: its compression flags, metadata and transform type. */
    int64_t check_grid_head(int64_t at, int64_t end, uint32_t file_version, const char *what) const;

private:
    uint32_t u32(int64_t at, int64_t end, const char *what, const char *field) const;
    /* Checks that `n` bytes at `at` end by `end`; returns at + n. */
    int64_t span(int64_t at, uint64_t n, int64_t end, const char *what, const char *field) const;
    /* A length-prefixed string (io::readString); its text (up to 64 bytes) into *text. */
    int64_t string(int64_t at, int64_t end, const char *what, const char *field, std::string *text) const;

    int fd_ = -1;
    int64_t size_ = 0;
    FdBuf buf_;
    std::istream is_;
};

} // namespace vwvdb

#endif
