/* query_sort.h — internal: in-place heapsorts for the server queries. The C library's qsort
 * may allocate (glibc's merge sort takes a malloc'd buffer for large arrays), and a tick
 * must allocate nothing (vis.h, vis_query_create); heapsort needs no memory and no recursion. */
#ifndef VIS_QUERY_SORT_H
#define VIS_QUERY_SORT_H

#include <stddef.h>
#include <stdint.h>

#define VIS_DEFINE_HEAPSORT_(name, type)                                                    \
    static inline void name(type *a, size_t n)                                               \
    {                                                                                        \
        for (size_t end = n, start = n / 2; end > 1;) {                                      \
            size_t root;                                                                     \
            if (start > 0) {                                                                 \
                root = --start;                                                              \
            } else {                                                                         \
                --end;                                                                       \
                type t = a[0];                                                               \
                a[0] = a[end];                                                               \
                a[end] = t;                                                                  \
                root = 0;                                                                    \
            }                                                                                \
            for (size_t child; (child = 2 * root + 1) < end; root = child) {                 \
                if (child + 1 < end && a[child] < a[child + 1])                              \
                    ++child;                                                                 \
                if (!(a[root] < a[child]))                                                   \
                    break;                                                                   \
                type t = a[root];                                                            \
                a[root] = a[child];                                                          \
                a[child] = t;                                                                \
            }                                                                                \
        }                                                                                    \
    }

VIS_DEFINE_HEAPSORT_(vis_sort_u64, uint64_t)
VIS_DEFINE_HEAPSORT_(vis_sort_u32, uint32_t)
VIS_DEFINE_HEAPSORT_(vis_sort_f64, double)

#endif
