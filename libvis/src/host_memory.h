/* host_memory.h — the allocator a context uses when its description gives none. */
#ifndef VIS_HOST_MEMORY_H
#define VIS_HOST_MEMORY_H

#include <stddef.h>

/* vis_allocator's alloc and free: blocks aligned to 64 bytes (align <= 64, else NULL). */
void *vis_default_alloc(size_t size, size_t align, void *user);
void vis_default_free(void *ptr, void *user);

/* A block of vis_default_alloc grown or shrunk, its first min(old_size, new_size) bytes
 * kept; large blocks grow in place (no copy). NULL on failure, the old block untouched. */
void *vis_default_realloc(void *ptr, size_t old_size, size_t new_size);

#endif
