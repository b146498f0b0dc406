/* slot_free.h — internal: size classes of leaf slots in a primitive pool, and the lists of
 * freed slots per class, so that a leaf that outgrows its slot leaves it for the next leaf of
 * that size instead of abandoning it (bounded memory under endless edits).
 *
 * Classes follow the usual allocator scheme (e.g. jemalloc's size classes): every size up to
 * 16 elements, then 8 classes per power of two, so a slot is at most 1/8 larger than asked.
 * A freed slot is linked through its first 4 bytes (every slot holds at least one element of
 * at least 4 bytes): the lists need no memory of their own, which keeps an edit's growth in
 * bytes exactly predictable (scene.c, set_object_growth). */
#ifndef VIS_SLOT_FREE_H
#define VIS_SLOT_FREE_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#define VIS_SLOT_CLASSES 240u
#define VIS_SLOT_REUSE_CLASSES 8u /* a free slot up to 8 classes (twice the size) up serves  */

typedef struct vis_slot_free {
    uint32_t head[VIS_SLOT_CLASSES];  /* first free slot of the class (valid when count > 0) */
    uint32_t count[VIS_SLOT_CLASSES];
    uint64_t entries;                 /* elements in all free slots                          */
} vis_slot_free;

/* Slots of classes no leaf asks for would still pile up (leaves that keep growing leave their
 * smaller slots behind), so a pool whose free slots exceed 1/16 of its used entries is
 * compacted after the edit (scene_compact.c): its slots copied in leaf order to a new array
 * of the live entries and 1/16 more. */
static inline int vis_slot_should_compact(uint64_t used, uint64_t free_entries)
{
    return used >= 4096u && free_entries * 16u > used;
}

/* The capacity a pool of cap entries keeps when compacted to `live` entries. */
static inline uint64_t vis_slot_compact_cap(uint64_t live, uint64_t cap)
{
    uint64_t c = live + live / 16u + 16u;
    return c < cap ? c : cap;
}

/* The class of a slot of n >= 1 elements (n <= 2^63). Classes from VIS_SLOT_CLASSES on are
 * only ever sized (vis_slot_class_size), never kept in a free list: the budget checks size
 * needs past the pools' 32-bit counts before refusing them. */
static inline uint32_t vis_slot_class(uint64_t n)
{
    if (n <= 16u)
        return n ? (uint32_t)n - 1u : 0u;
    uint32_t e = 63u - (uint32_t)__builtin_clzll(n - 1u); /* 2^e < n <= 2^(e+1), e >= 4 */
    uint64_t step = (uint64_t)1 << (e - 3u);
    uint64_t k = (n - ((uint64_t)1 << e) + step - 1u) / step; /* 1..8 */
    return 16u + (e - 4u) * 8u + (uint32_t)k - 1u;
}

/* Elements of a slot of class c. */
static inline uint64_t vis_slot_class_size(uint32_t c)
{
    if (c < 16u)
        return c + 1u;
    uint32_t e = 4u + (c - 16u) / 8u, k = (c - 16u) % 8u + 1u;
    return ((uint64_t)1 << e) + (uint64_t)k * ((uint64_t)1 << (e - 3u));
}

/* Where a slot of class c0 comes from: the first class of c0 .. c0 + VIS_SLOT_REUSE_CLASSES - 1
 * with a free slot, or UINT32_MAX (a new slot of class c0 at the end of the pool). `delta`
 * (may be NULL) adds to each class's free count: set_object_growth's prediction of an edit
 * walks the same rule with the slots earlier moves of the edit took and freed. */
static inline uint32_t vis_slot_free_class(const vis_slot_free *f, const int32_t *delta, uint32_t c0)
{
    for (uint32_t c = c0; c < c0 + VIS_SLOT_REUSE_CLASSES && c < VIS_SLOT_CLASSES; ++c)
        if ((int64_t)f->count[c] + (delta ? delta[c] : 0) > 0)
            return c;
    return UINT32_MAX;
}

/* Takes a free slot of class c from the pool (element size elem); returns its offset, or
 * UINT32_MAX when the class has none. */
static inline uint32_t vis_slot_take(vis_slot_free *f, const void *pool, size_t elem, uint32_t c)
{
    if (!f->count[c])
        return UINT32_MAX;
    uint32_t off = f->head[c];
    memcpy(&f->head[c], (const char *)pool + (size_t)off * elem, sizeof(uint32_t));
    --f->count[c];
    f->entries -= vis_slot_class_size(c);
    return off;
}

/* Gives the slot at `off` of class c back. */
static inline void vis_slot_give(vis_slot_free *f, void *pool, size_t elem, uint32_t off, uint32_t c)
{
    memcpy((char *)pool + (size_t)off * elem, &f->head[c], sizeof(uint32_t));
    f->head[c] = off;
    ++f->count[c];
    f->entries += vis_slot_class_size(c);
}

#endif
