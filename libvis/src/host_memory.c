/* host_memory.c — the default allocator: small blocks from aligned_alloc, large ones as
 * mapped pages that grow in place.
 *
 * Why: a scene's pools grow by 1/8 at a time (scene.c grown_cap, to keep their slack within
 * the memory goal), so a world built object by object copies each pool about eight times
 * over, and every copy faults in fresh pages: on gen:large that was a quarter of the build's
 * CPU time (docs/performance.md, "The build's copies"). A mapping grows with mremap, which
 * moves page-table entries instead of bytes, and asks for huge pages. Blocks carry a 64-byte
 * header that says which kind they are, so free and realloc never guess. Under a sanitizer every block comes from
 * aligned_alloc (below); mappings are also invisible to LeakSanitizer and Valgrind's leak
 * check, which see the small blocks only. */
#define _GNU_SOURCE /* mremap */
#include "host_memory.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#define VIS_HAVE_MREMAP 1
#endif

/* Sanitizers see heap blocks, not mappings: AddressSanitizer does not check them, and
 * ThreadSanitizer does not follow mremap (a range a block moved out of keeps its old
 * accesses, and reports races with whatever is mapped there next). */
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#undef VIS_HAVE_MREMAP
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#undef VIS_HAVE_MREMAP
#endif
#endif

#define HEADER 64u                      /* keeps the payload 64-byte aligned           */
#define MAPPED_FROM ((size_t)1 << 20)   /* blocks of 1 MiB and more are mappings       */
#define KIND_HEAP 0x68656170u
#define KIND_MAP 0x6D617070u

typedef struct block_header {
    uint32_t kind;
    uint32_t pad;
    size_t length; /* KIND_MAP: bytes mapped, header included */
} block_header;

static block_header *header_of(void *ptr) { return (block_header *)((unsigned char *)ptr - HEADER); }

#ifdef VIS_HAVE_MREMAP
static size_t map_length(size_t size)
{
    long ps = sysconf(_SC_PAGESIZE);
    size_t page = ps > 0 ? (size_t)ps : 4096;
    if (size > SIZE_MAX - HEADER - page)
        return 0;
    return (size + HEADER + page - 1) / page * page;
}

static void *map_block(size_t size)
{
    size_t len = map_length(size);
    if (!len)
        return NULL;
    void *base = mmap(NULL, len, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (base == MAP_FAILED)
        return NULL;
#if defined(MADV_HUGEPAGE)
    /* Transparent huge pages where the system offers them on request (Linux's "madvise"
     * mode): one fault per 2 MiB instead of per 4 KiB as the pools and the CPU backend's
     * labels are first written, which on a virtual machine cost more than the writing
     * (docs/performance.md, "Huge pages for the large blocks"). A hint: failure changes
     * nothing. */
    madvise(base, len, MADV_HUGEPAGE);
#endif
    block_header *h = base;
    h->kind = KIND_MAP;
    h->length = len;
    return (unsigned char *)base + HEADER;
}
#endif

static void *heap_block(size_t size)
{
    if (size > SIZE_MAX - 2 * HEADER)
        return NULL;
    size_t rounded = (size + HEADER - 1) / HEADER * HEADER + HEADER;
    block_header *h = aligned_alloc(HEADER, rounded);
    if (!h)
        return NULL;
    h->kind = KIND_HEAP;
    h->length = 0;
    return (unsigned char *)h + HEADER;
}

void *vis_default_alloc(size_t size, size_t align, void *user)
{
    (void)user;
    if (align > HEADER)
        return NULL;
#ifdef VIS_HAVE_MREMAP
    if (size >= MAPPED_FROM)
        return map_block(size);
#endif
    return heap_block(size);
}

void vis_default_free(void *ptr, void *user)
{
    (void)user;
    if (!ptr)
        return;
    block_header *h = header_of(ptr);
#ifdef VIS_HAVE_MREMAP
    if (h->kind == KIND_MAP) {
        munmap(h, h->length);
        return;
    }
#endif
    free(h);
}

void *vis_default_realloc(void *ptr, size_t old_size, size_t new_size)
{
    if (!ptr)
        return vis_default_alloc(new_size, HEADER, NULL);
#ifdef VIS_HAVE_MREMAP
    block_header *h = header_of(ptr);
    if (h->kind == KIND_MAP && new_size >= MAPPED_FROM) {
        size_t len = map_length(new_size);
        if (!len)
            return NULL;
        if (len == h->length)
            return ptr;
        void *base = mremap(h, h->length, len, MREMAP_MAYMOVE);
        if (base == MAP_FAILED)
            return NULL; /* the old mapping is untouched */
        h = base;
        h->length = len;
        return (unsigned char *)base + HEADER;
    }
#endif
    void *p = vis_default_alloc(new_size, HEADER, NULL);
    if (!p)
        return NULL;
    memcpy(p, ptr, old_size < new_size ? old_size : new_size);
    vis_default_free(ptr, NULL);
    return p;
}
