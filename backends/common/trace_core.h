/*
 * trace_core.h — the ray pass, written once for C11 and OpenCL C 1.2.
 *
 * The CPU backend includes this file; the OpenCL backend embeds it (cmake/embed_kernels.cmake)
 * ahead of the kernels. Both therefore execute the same operations in the same order, and
 * with FP contraction off on both sides (-ffp-contract=off / FP_CONTRACT OFF) and correctly
 * rounded division and square root, their ID and depth buffers are bit-identical.
 *
 * Sources:
 *  - kd-tree stack traversal with 8-byte entries (node, t_max): Chang & Ihm 2010
 *    (seeds/000), after Havran's TA_B; front to back, stop once the next node starts
 *    beyond the best hit.
 *  - Inside a leaf, quads are bucketed by (axis, integer plane) and visited in the order the
 *    ray crosses those planes, a 3D-DDA over planes (Amanatides & Woo 1987; Lee & Han 2005,
 *    seeds/001, for front-to-back order in uniform sub-volumes). The hit distance of a quad
 *    is computed by the very expression that orders the planes, so stopping at the first
 *    plane beyond the best hit is exact.
 *  - Watertight ray/triangle test: Woop, Benthin, Wald, JCGT 2013.
 *
 * Numerics: every distance is t = (plane - o[a]) * inv_d[a] with inv_d = 1/d correctly
 * rounded; directions with a +0 or -0 component never divide (parallel planes are skipped
 * explicitly), so no NaN arises. Ties in t go to the lowest object ID. The quad test is
 * conservative -- a ray that touches the closed rectangle, within the rounding of its
 * distances, hits it -- and decided from the tree walk's own distances with the walk's slack
 * (vis_quad_intersect has the bound and its derivation), so every method equals the brute
 * force.
 */
#ifndef VIS_TRACE_CORE_H
#define VIS_TRACE_CORE_H

#ifdef __OPENCL_VERSION__
#  pragma OPENCL FP_CONTRACT OFF
typedef uint uint32_t;
typedef int int32_t;
typedef ulong vis_u64;
#  define VIS_GLOBAL __global
#  define VIS_INLINE static inline
#  define VIS_NOINLINE static inline
#  define VIS_INF INFINITY
#  define VIS_SQRTF sqrt
#  define VIS_FABSF fabs
#else
#  include <math.h>
#  include <stdint.h>
typedef uint64_t vis_u64;
#  define VIS_GLOBAL
#  define VIS_INLINE static inline
/* A function kept out of line on the CPU, where the small part in front of it should inline
 * into its callers (the device compiler inlines as it sees fit). */
#  define VIS_NOINLINE static __attribute__((noinline, unused))
#  define VIS_INF INFINITY
#  define VIS_SQRTF sqrtf
#  define VIS_FABSF fabsf
#endif

/* ---- flat scene layout (shared with the host, copied to devices as is) --------------- */

/* Inner node: info = axis (0..2) | first_child << 2; children are first_child, first_child+1.
 * Leaf: info = 3 | leaf_index << 2. */
typedef struct vis_kd_node {
    float split;
    uint32_t info;
} vis_kd_node;

#define VIS_NODE_LEAF 3u

/* A leaf (64 bytes). Its bucket table (at bucket_offset in the bucket pool, vis_bucket_words
 * entries) holds the bucket offsets (below) and then each bucket's two cover masks
 * (vis_cover_bits). Its primitives live in two pools: triangles in the triangle pool, quads
 * in the quad pool of 4-byte words, where the leaf's slot holds, in this order:
 *  - its object table at table_offset: the object slots of its packed quads (the table index
 *    is what a packed quad names, so a quad takes one word and not a 24-bit slot);
 *  - its packed quads at quad_offset (quad_count words, vis_packed_quad below): quads whose
 *    plane lies on an integer offset k in [0, E[a]] from lo[a] and whose rectangle lies on
 *    integer offsets in [0, 31] from the leaf's lower corner, sorted by axis then k: bucket
 *    (a, k) spans [buckets[bucket_offset + base(a) + k], ... + 1) relative to quad_offset,
 *    where base(0) = 0, base(1) = E0 + 1, base(2) = E0 + E1 + 2;
 *  - its loose quads right after them, at quad_offset + quad_count (loose_count vis_flat_quad,
 *    six words each): every other quad, always tested.
 * Packed coordinates are exact: the scene packs a quad only when lo + offset gives back its
 * float coordinates bit for bit, so the tests see the same numbers either way.
 * content_box is the closed box, in the same offsets, that holds every packed quad (plane and
 * rectangle): lo[0..2] | hi[0..2] as six 5-bit fields (VIS_BOX_FIELD), each offset capped at
 * 31; a high field of 31 stands for "up to the leaf's last plane" (planes may lie up to E[a],
 * rectangles up to 31), a capped low field is only lower than the truth. The per-ray leaf walk
 * clips the ray to it (vis_leaf_intersect). 0 when the leaf has no packed quad. */
typedef struct vis_flat_leaf {
    float lo[3];
    float hi[3];
    uint32_t quad_offset;   /* first packed quad (word) in the quad pool                   */
    uint32_t quad_count;    /* packed quads                                                */
    uint32_t bucket_offset; /* first entry of this leaf's bucket table                     */
    uint32_t dims_xy;       /* E0 | E1 << 16                                               */
    uint32_t dims_z;        /* E2                                                          */
    uint32_t content_box;   /* box of the packed quads: offsets lo0|lo1|lo2|hi0|hi1|hi2, 5 bits each */
    uint32_t loose_count;   /* loose quads, at quad_offset + quad_count in the quad pool    */
    uint32_t tri_offset;    /* triangles in the triangle pool                              */
    uint32_t tri_count;
    uint32_t table_offset;  /* the object table in the quad pool (a word index)             */
} vis_flat_leaf;

/* Whether a leaf holds anything a ray can hit: the walks' test for an empty leaf, and what
 * the cell map's clearances and the packets' subtree fills are kept from. */
VIS_INLINE int vis_leaf_has_primitives(const VIS_GLOBAL vis_flat_leaf *lf)
{
    return (lf->quad_count | lf->loose_count | lf->tri_count) != 0u;
}

/* A quad as given (24 bytes; loose quads are stored so): meta = object_index << 8 | flags << 2 | axis. */
typedef struct vis_flat_quad {
    float plane, u0, v0, u1, v1;
    uint32_t meta;
} vis_flat_quad;

/* A packed quad (one uint32_t word): u0 | v0 << 5 | u1 << 10 | v1 << 15 | flags << 20 |
 * table index << 22, the rectangle as offsets from the leaf's lower corner on the bucket's u
 * and v axes. */
#define VIS_LOOSE_WORDS 6u /* words of a loose quad in the quad pool                      */
#define VIS_PQ_COORD_MAX 31u
#define VIS_PQ_FLAGS_MAX 3u
#define VIS_PQ_TABLE_MAX 1023u
#define VIS_PQ_FIELD(w, i) (((w) >> (5u * (i))) & 31u) /* i: 0 u0, 1 v0, 2 u1, 3 v1 */
#define VIS_PQ_FLAGS(w) (((w) >> 20) & 3u)
#define VIS_PQ_TABLE(w) ((w) >> 22)
/* Field i of a leaf's content_box: i = 0..2 the low offset on axis i, 3..5 the high one. */
#define VIS_BOX_FIELD(b, i) (((b) >> (5u * (i))) & 31u)

/* A bucket's cover masks: where on its plane its packed quads lie, so that the per-ray leaf
 * walk reads a bucket only when one of its quads can lie at the ray's crossing. Bit j of the
 * u mask is set when a quad of the bucket covers the unit cell [j, j + 1] of offsets on the
 * bucket's u axis (a quad [u0, u1] covers [u0, max(u0, u1 - 1)], vis_cover_bits), and the v
 * mask likewise: the quads' shadows on the two axes, not their rectangles (on the views
 * measured the two shadows let through about as few buckets as a rectangle mask of 2x2
 * cells, at less than half the cost of its test: docs/performance.md, "Buckets read only
 * where their quads lie"). The masks of bucket b are the words at bucket_offset +
 * vis_bucket_offsets + 2b (u) and + 2b + 1 (v), built with the leaf (libvis/src/scene.c). */
VIS_INLINE uint32_t vis_bucket_offsets(uint32_t e0, uint32_t e1, uint32_t e2)
{
    return e0 + e1 + e2 + 4u; /* one per bucket (axis a, plane 0..E[a]), and the end */
}

VIS_INLINE uint32_t vis_bucket_words(uint32_t e0, uint32_t e1, uint32_t e2)
{
    uint32_t offsets = vis_bucket_offsets(e0, e1, e2);
    return offsets + 2u * (offsets - 1u);
}

/* The bits lo..hi (0 <= lo <= hi <= 31); 2u << 31 wraps to 0, which still gives lo..31. */
VIS_INLINE uint32_t vis_cover_bits(int lo, int hi)
{
    return (2u << hi) - (1u << lo);
}

/* A triangle as traced (40 bytes), meta as for quads (axis bits unused). */
typedef struct vis_flat_tri {
    float v0[3], v1[3], v2[3];
    uint32_t meta;
} vis_flat_tri;

/* An object slot: its ID (0 = free slot) and the leaves that reference it. */
typedef struct vis_flat_object {
    uint32_t id;
    uint32_t leaf_offset; /* into object_leaves                                           */
    uint32_t leaf_count;
    uint32_t pad;
} vis_flat_object;

/* Ropes (Popov et al. 2007; Chang & Ihm 2010): for a node that has them, its box and the
 * node on the other side of each of its six faces (-x,+x,-y,+y,-z,+z; VIS_NO_ROPE = the
 * outside): the smallest node covering that face, never deeper than the node itself.
 * rope_index[node] gives the node's entry in `ropes`, or VIS_NO_ROPE. Every node at most
 * VIS_MAX_SHORT_STACK levels above the leaves has one; entry i < leaf count is leaf i
 * (libvis/src/kdtree.c builds them once, for the first pass that walks them; until then
 * rope_index[node] is VIS_NO_ROPE for every node). */
typedef struct vis_rope_node {
    float lo[3], hi[3];
    uint32_t link[6];
    uint32_t node;
    uint32_t height; /* levels from the node down to its deepest leaf (0: a leaf)           */
} vis_rope_node;

#define VIS_NO_ROPE 0xFFFFFFFFu

/* A cell map entry (rope_index[cell_map + cell], the cell-grid walk's): the cell's leaf in the
 * low VIS_CELL_LEAF_BITS bits (leaves <= nodes <= VIS_MAX_KD_NODES = 2^26, kdtree.c asserts
 * it), and above them the cell's clearance: 0 where the leaf may hold primitives, else a
 * number c >= 1 such that every cell within c - 1 steps of it on each axis (Chebyshev
 * distance c - 1) has an empty leaf, at most VIS_CELL_CLEAR_MAX. libvis keeps it at the
 * distance to the nearest cell whose leaf holds primitives, through every edit that fills or
 * empties a leaf (kdtree.c). */
#define VIS_CELL_LEAF_BITS 26u
#define VIS_CELL_LEAF(e) ((e) & ((1u << VIS_CELL_LEAF_BITS) - 1u))
#define VIS_CELL_CLEAR(e) ((e) >> VIS_CELL_LEAF_BITS)
/* 4: the views measured read the same cells with 8 (the counts in docs/performance.md, "Empty
 * cells stepped over unread"), and a leaf's first primitives then rewrite at most 7^3 entries,
 * not 15^3 (on gen:default's build 4 k instructions per filled leaf instead of 14 k). */
#define VIS_CELL_CLEAR_MAX 4u
/* Deepest short stack (and rope level) a pass may ask for. vis.h defines the same name with
 * the same tokens (the device compiler cannot include vis.h); backends/backend.h asserts
 * that the two agree. */
#define VIS_MAX_SHORT_STACK 16u

#define VIS_META_AXIS(m) ((m) & 3u)
#define VIS_META_FLAGS(m) (((m) >> 2) & 63u)
#define VIS_META_OBJECT(m) ((m) >> 8)
#define VIS_NO_OBJECT 0xFFFFFFFFu

/* The per-pass parameters, filled by the host (camera basis in float, from double). */
typedef struct vis_ray_setup {
    float origin[3];     /* eye, scene-local                                               */
    float forward[3];    /* f                                                              */
    float right[3];      /* r * tan(fovy/2) * aspect                                       */
    float up[3];         /* u * tan(fovy/2)                                                */
    float t_near, t_far; /* t_far may be +inf                                              */
    float size[3];       /* scene bounds [0, size]                                         */
    uint32_t width, height;
    uint32_t id_mode;    /* 0 object IDs, 1 leaf IDs                                       */
    uint32_t traversal;  /* vis_traversal                                                  */
    uint32_t root;       /* root node index (0)                                            */
    uint32_t leaf_count;
    uint32_t short_stack; /* N of shortstack / ropes-shortstack, 1..VIS_MAX_SHORT_STACK       */
    uint32_t cells[3];    /* the scene's cell grid (the DDA method, vis_traverse_dda)          */
    uint32_t cell_map;    /* rope_index[cell_map + cell]: cell (x + nx (y + ny z))'s leaf and
                             clearance (VIS_CELL_LEAF, VIS_CELL_CLEAR);
                             0: the scene has no map (its leaves are not single cells)       */
    float cell_size;      /* split planes lie on (float)i * cell_size                          */
} vis_ray_setup;

/* The scene arrays, as separate parameters because OpenCL 1.2 kernels cannot take structs
 * of pointers. */
/* On the CPU the scene arrays end with the CPU backend's voxel labels (labels, NULL where a
 * caller has none: vis_label_walk below); the devices walk planes and take no such array. */
#ifdef __OPENCL_VERSION__
#  define VIS_LABELS_PARAM
#  define VIS_LABELS_ARG
#else
#  define VIS_LABEL_WALK 1
#  define VIS_LABELS_PARAM , const uint32_t *labels
#  define VIS_LABELS_ARG , labels
#endif
#define VIS_SCENE_PARAMS                                                                     \
    const VIS_GLOBAL vis_kd_node *nodes, const VIS_GLOBAL vis_flat_leaf *leaves,              \
        const VIS_GLOBAL uint32_t *buckets, const VIS_GLOBAL uint32_t *quads,                  \
        const VIS_GLOBAL vis_flat_tri *tris, const VIS_GLOBAL vis_flat_object *objects,       \
        const VIS_GLOBAL uint32_t *object_leaves, const VIS_GLOBAL vis_rope_node *ropes,       \
        const VIS_GLOBAL uint32_t *rope_index VIS_LABELS_PARAM
#define VIS_SCENE_ARGS nodes, leaves, buckets, quads, tris, objects, object_leaves, ropes, rope_index VIS_LABELS_ARG

/* Material flags of a primitive (meta's flags field): vis.h's VIS_PRIM_* (backend.h checks). */
#define VIS_FLAG_SEE_THROUGH 1u
#define VIS_FLAG_REFLECTIVE 2u

/* Effects of a pass (vis_effect_setup.effects): vis.h's VIS_EFFECT_* (backend.h checks). */
#define VIS_FX_SEE_THROUGH 1u
#define VIS_FX_REFLECT 2u
#define VIS_FX_SHADOWS 4u
#define VIS_FX_FOG 8u
/* The most see-through objects a ray records (vis.h's VIS_MAX_SEE_THROUGH_LAYERS). */
#define VIS_MAX_LAYERS 4u

/* The per-pass effect parameters (fog is already in vis_ray_setup.t_far). */
typedef struct vis_effect_setup {
    float light[3];     /* toward the light, normalised in double then rounded (shadows)   */
    uint32_t effects;   /* VIS_FX_*                                                         */
    uint32_t layers;    /* see-through objects recorded per pixel, 1..VIS_MAX_LAYERS        */
    uint32_t pad[3];
} vis_effect_setup;

/* Hit state of one ray. */
typedef struct vis_hit {
    float t;          /* best distance so far (+inf: none)                                  */
    uint32_t object;  /* object slot index of the best hit, VIS_NO_OBJECT if none           */
    uint32_t id;      /* its ID (for the tie rule), 0 if none                               */
#ifdef VIS_TRACE_EFFECTS
    /* The effects instance (a program or translation unit built with VIS_TRACE_EFFECTS; the
     * plain pass compiles none of this). The hit primitive is kept for the secondary rays,
     * and ties in (t, ID) go on to (prim, plane), so that every method keeps the same one. */
    uint32_t prim;    /* axis (3: a triangle) | flags << 2 of the best hit                 */
    float plane;      /* its plane (quads; 0 for triangles)                                */
    uint32_t policy;  /* VIS_ST_*: what a see-through primitive does to this ray           */
    uint32_t layers;  /* VIS_ST_RECORD: how many to keep                                    */
    uint32_t ignore_axis;  /* quads in this plane are not offered (VIS_NO_AXIS: none)      */
    float ignore_plane;
    uint32_t st_n;         /* see-through objects kept, nearest first by (t, ID)            */
    float st_t[VIS_MAX_LAYERS];
    uint32_t st_id[VIS_MAX_LAYERS];
    float rt;              /* the nearest reflective see-through crossing (rid 0: none)     */
    uint32_t rid, rprim;
    float rplane;
#endif
} vis_hit;

typedef struct vis_ray {
    float o[3], d[3], inv[3];
    float t_near, t_far;
} vis_ray;

/* ---- ray generation ----------------------------------------------------------------- */

/* A direction component below the smallest normal float (|d| < 2^-126) is taken as 0 by every
 * ray this library makes, for every method alike: its reciprocal would be infinite, and an
 * infinite reciprocal times a zero offset is NaN (a ray starting on a cell boundary), which
 * the tree walk and the cell-grid walk would read differently from the brute force. */
VIS_INLINE float vis_dir_component(float d)
{
    return VIS_FABSF(d) < 1.17549435e-38f ? 0.0f : d;
}

VIS_INLINE void vis_ray_for_pixel(const vis_ray_setup *s, uint32_t x, uint32_t y, vis_ray *r)
{
    /* Pixel centre in NDC: (2x+1)/W - 1 and 1 - (2y+1)/H, exact integers then one rounding. */
    float nx = (float)(2u * x + 1u) / (float)s->width - 1.0f;
    float ny = 1.0f - (float)(2u * y + 1u) / (float)s->height;
    float d[3];
    for (int a = 0; a < 3; ++a) {
        float w = s->forward[a] + nx * s->right[a];
        d[a] = w + ny * s->up[a];
    }
    float len = VIS_SQRTF(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int a = 0; a < 3; ++a) {
        r->o[a] = s->origin[a];
        r->d[a] = vis_dir_component(d[a] / len);
        /* 1/(+-0) = +-inf is never used: every user checks d[a] == 0 first. */
        r->inv[a] = 1.0f / r->d[a];
    }
    r->t_near = s->t_near;
    r->t_far = s->t_far;
}

/* ---- primitives --------------------------------------------------------------------- */

VIS_INLINE int vis_hit_better(float t, uint32_t id, const vis_hit *h)
{
    return t < h->t || (t == h->t && id < h->id);
}

/* Makes (t, object slot obj) the ray's hit when it beats the current one (vis_hit_better). */
VIS_INLINE void vis_hit_offer(float t, uint32_t obj, const VIS_GLOBAL vis_flat_object *objects, vis_hit *h)
{
    uint32_t id = objects[obj].id;
    if (vis_hit_better(t, id, h)) {
        h->t = t;
        h->object = obj;
        h->id = id;
    }
}

#ifdef VIS_TRACE_EFFECTS
#define VIS_ST_OCCLUDE 0u /* see-through primitives occlude like any other (effect off)     */
#define VIS_ST_RECORD 1u  /* they never occlude; the nearest `layers` objects are recorded  */
#define VIS_ST_SKIP 2u    /* they are not there (secondary rays)                              */
#define VIS_NO_AXIS 7u

VIS_INLINE void vis_hit_init(vis_hit *h, uint32_t policy, uint32_t layers, uint32_t ignore_axis, float ignore_plane)
{
    h->t = VIS_INF;
    h->object = VIS_NO_OBJECT;
    h->id = 0u;
    h->prim = 0u;
    h->plane = 0.0f;
    h->policy = policy;
    h->layers = layers;
    h->ignore_axis = ignore_axis;
    h->ignore_plane = ignore_plane;
    h->st_n = 0u;
    for (uint32_t i = 0u; i < VIS_MAX_LAYERS; ++i) {
        h->st_t[i] = VIS_INF;
        h->st_id[i] = 0u;
    }
    h->rt = VIS_INF;
    h->rid = 0u;
    h->rprim = 0u;
    h->rplane = 0.0f;
}

/* The total order of hits: (t, ID), then (prim, plane), so a tie between two primitives of
 * one object resolves the same whichever a method offers first. */
VIS_INLINE int vis_prim_better(float t, uint32_t id, uint32_t prim, float plane, float bt, uint32_t bid, uint32_t bprim,
                               float bplane)
{
    if (t != bt)
        return t < bt;
    if (id != bid)
        return id < bid;
    if (prim != bprim)
        return prim < bprim;
    return plane < bplane;
}

/* A see-through crossing (policy VIS_ST_RECORD): the object joins the ray's list of the
 * `layers` nearest distinct objects by (t, ID), an object offered again keeping its smallest
 * t; a reflective one is also the reflector candidate if it is the nearest so far. */
VIS_INLINE void vis_see_through_offer(float t, uint32_t id, uint32_t prim, float plane, vis_hit *h)
{
    if ((prim >> 2 & VIS_FLAG_REFLECTIVE) && vis_prim_better(t, id, prim, plane, h->rt, h->rid, h->rprim, h->rplane)) {
        h->rt = t;
        h->rid = id;
        h->rprim = prim;
        h->rplane = plane;
    }
    uint32_t n = h->st_n;
    for (uint32_t i = 0u; i < n; ++i)
        if (h->st_id[i] == id) {
            if (!(t < h->st_t[i]))
                return;
            for (uint32_t j = i; j + 1u < n; ++j) { /* taken out; put back at its new place */
                h->st_t[j] = h->st_t[j + 1u];
                h->st_id[j] = h->st_id[j + 1u];
            }
            --n;
            break;
        }
    uint32_t at = n;
    while (at > 0u && (t < h->st_t[at - 1u] || (t == h->st_t[at - 1u] && id < h->st_id[at - 1u])))
        --at;
    if (at >= h->layers) {
        h->st_n = n;
        return;
    }
    if (n == h->layers)
        --n; /* the farthest drops out */
    for (uint32_t j = n; j > at; --j) {
        h->st_t[j] = h->st_t[j - 1u];
        h->st_id[j] = h->st_id[j - 1u];
    }
    h->st_t[at] = t;
    h->st_id[at] = id;
    h->st_n = n + 1u;
}
#endif

/* vis_hit_offer for a primitive with its axis (3: a triangle), flags and plane. The plain
 * pass ignores all three (the compiler drops them); the effects instance applies the ray's
 * see-through policy and ignored plane, and breaks ties by primitive. */
VIS_INLINE void vis_hit_offer_prim(float t, uint32_t obj, uint32_t axis, uint32_t flags, float plane,
                                   const VIS_GLOBAL vis_flat_object *objects, vis_hit *h)
{
#ifdef VIS_TRACE_EFFECTS
    if (axis == h->ignore_axis && plane == h->ignore_plane)
        return; /* the reflector's or receiver's own plane: a ray leaving it cannot meet it */
    uint32_t id = objects[obj].id, prim = axis | flags << 2;
    if ((flags & VIS_FLAG_SEE_THROUGH) && h->policy != VIS_ST_OCCLUDE) {
        if (h->policy == VIS_ST_RECORD)
            vis_see_through_offer(t, id, prim, plane, h);
        return;
    }
    if (vis_prim_better(t, id, prim, plane, h->t, h->id, h->prim, h->plane)) {
        h->t = t;
        h->object = obj;
        h->id = id;
        h->prim = prim;
        h->plane = plane;
    }
#else
    (void)axis, (void)flags, (void)plane;
    vis_hit_offer(t, obj, objects, h);
#endif
}

/* Distance slack: two distances computed independently (each within 3 ulps of the exact
 * distance of the float ray: t = fl(fl(c - o[a]) * fl(1/d[a])), 3 roundings) are taken to
 * coincide when they are within 2^-20 relative of each other. 2^-20 = 16 units of 2^-24,
 * against at most 6 for two such distances. Used, with the same expressions, by the quad
 * test, by every decision of the tree walk and by the termination test. */
VIS_INLINE float vis_t_limit(float t)
{
    return t + t * 9.5367431640625e-07f; /* 2^-20 */
}

/* Two distances that coincide within the slack. */
VIS_INLINE int vis_t_tie(float x, float y)
{
    return x <= vis_t_limit(y) && y <= vis_t_limit(x);
}

/* Narrows [*t_in, *t_out] to where the ray lies in the slab lo <= x[a] <= hi, with the
 * expressions of the tree walk's split distances. A ray parallel to the slab (d[a] = +-0)
 * lies in it or not: returns 0 when it does not. */
VIS_INLINE int vis_slab(const vis_ray *r, uint32_t a, float lo, float hi, float *t_in, float *t_out)
{
    float o = r->o[a], d = r->d[a];
    if (d == 0.0f)
        return o >= lo && o <= hi;
    float t_lo = (lo - o) * r->inv[a], t_hi = (hi - o) * r->inv[a];
    float t0 = d > 0.0f ? t_lo : t_hi, t1 = d > 0.0f ? t_hi : t_lo;
    if (t0 > *t_in)
        *t_in = t0;
    if (t1 < *t_out)
        *t_out = t1;
    return 1;
}

/* The quad test, conservative where rounding decides a touch (DESIGN.md, "Numerics").
 *
 * A ray through a convex voxel edge touches both faces that meet there. Testing where the
 * ray crosses each face's plane (o + t d in float, compared with the rectangle) decides each
 * face from its own rounded point, and both can fall outside: the ray slips through the edge
 * and sees what lies behind. (A test that widens that point by its rounding bound, a few ulps
 * of |o| + |t d|, fixes the slip but reaches past the leaf that holds the quad, where the
 * tree walk, deciding from split distances, does not go: the per-ray methods would no longer
 * equal the brute force.)
 *
 * So the quad is tested as the slab test of its box [plane, plane] x [u0, u1] x [v0, v1]:
 * the distances at which the ray enters and leaves each slab, t = (c - o[a]) * inv[a], hit
 * when the latest entry is no later than the earliest exit, within vis_t_limit. Those are the
 * very expressions of the tree walk's split distances (vis_node_decide), the leaf boxes and
 * the scene box (vis_clip_scene), compared with the same slack, so whatever the quad test
 * hits lies in a leaf that the walk enters (docs/traversal.md, "Exactness").
 *
 * The bound. Let t* be the exact distances of the float ray (o, d). Each computed distance is
 * t* (1 + e) with |e| <= 3u + O(u^2), u = 2^-24 (the subtraction, 1/d, the product; no FMA).
 * Where the exact ray touches the rectangle (on an edge or a corner, entry = exit), the
 * computed entry and exit differ by at most 6u t; the slack is 16u t (less 1u for computing
 * it), so every touch of the closed rectangle is a hit. The remaining 9u is what a camera
 * aimed at the point adds: the centre pixel of an odd-sized image has d = fl(F / |F|), F =
 * fl(f), whose ratios d[u] / d[a] are within 4u of f's, so its distances to the two planes
 * of an edge differ by at most 4u more (with the eye representable in float). What the ray
 * misses by more than the slack is no hit: a ray passing a quad's edge at distance x (along
 * the u axis) is a hit only while x <= 2^-20 |t d[u]| (0.0005 voxel at 512 voxels' reach).
 * tests/test_trace.c holds this to a double-precision reference on rays aimed at edges and
 * corners. Two quads sharing an edge see the same distance to it, so no ray slips between
 * them.
 *
 * vis_quad_slab: the test for the quad's rectangle on axes u, v, given the distance t to its
 * plane (the walk of a leaf's planes has it already). */
VIS_INLINE int vis_quad_slab(const vis_ray *r, uint32_t u, uint32_t v, float t, float u0, float v0, float u1,
                             float v1)
{
    float t_in = t, t_out = t;
    if (!vis_slab(r, u, u0, u1, &t_in, &t_out) || !vis_slab(r, v, v0, v1, &t_in, &t_out))
        return 0;
    return t_in <= vis_t_limit(t_out);
}

/* The quad test from scratch; the distance to the plane through *t_out. */
VIS_INLINE int vis_quad_intersect(const vis_ray *r, uint32_t axis, float plane, float u0, float v0,
                                  float u1, float v1, float *t_out)
{
    if (r->d[axis] == 0.0f)
        return 0; /* parallel to the plane, including rays lying in it */
    uint32_t u = axis == 2u ? 0u : axis + 1u;
    uint32_t v = axis == 0u ? 2u : axis - 1u;
    float t = (plane - r->o[axis]) * r->inv[axis];
    *t_out = t;
    return vis_quad_slab(r, u, v, t, u0, v0, u1, v1);
}

/* The loose quads of a leaf (six-word records in the quad pool). */
VIS_INLINE const VIS_GLOBAL vis_flat_quad *vis_loose_quads(const VIS_GLOBAL uint32_t *quads,
                                                           const VIS_GLOBAL vis_flat_leaf *leaf)
{
    return (const VIS_GLOBAL vis_flat_quad *)(quads + leaf->quad_offset + leaf->quad_count);
}

/* Packed quad w of the leaf's bucket (a, k), unpacked: the numbers it was packed from. */
VIS_INLINE vis_flat_quad vis_unpack_quad(uint32_t w, uint32_t a, int k, const VIS_GLOBAL vis_flat_leaf *leaf,
                                         const VIS_GLOBAL uint32_t *quads)
{
    uint32_t u = a == 2u ? 0u : a + 1u, v = a == 0u ? 2u : a - 1u;
    vis_flat_quad q;
    q.plane = leaf->lo[a] + (float)k;
    q.u0 = leaf->lo[u] + (float)VIS_PQ_FIELD(w, 0u);
    q.v0 = leaf->lo[v] + (float)VIS_PQ_FIELD(w, 1u);
    q.u1 = leaf->lo[u] + (float)VIS_PQ_FIELD(w, 2u);
    q.v1 = leaf->lo[v] + (float)VIS_PQ_FIELD(w, 3u);
    q.meta = quads[leaf->table_offset + VIS_PQ_TABLE(w)] << 8 | VIS_PQ_FLAGS(w) << 2 | a;
    return q;
}

VIS_INLINE void vis_test_quad(const vis_ray *r, vis_flat_quad q, const VIS_GLOBAL vis_flat_object *objects,
                              vis_hit *h)
{
    float t;
    if (!vis_quad_intersect(r, VIS_META_AXIS(q.meta), q.plane, q.u0, q.v0, q.u1, q.v1, &t))
        return;
    if (t < r->t_near || t > r->t_far || t > h->t)
        return;
    vis_hit_offer_prim(t, VIS_META_OBJECT(q.meta), VIS_META_AXIS(q.meta), VIS_META_FLAGS(q.meta), q.plane, objects, h);
}

/* Watertight ray/triangle intersection (Woop, Benthin, Wald 2013), two-sided. Returns the
 * distance through *t_out. The double-precision fallback for zero edge functions is the
 * paper's; it runs where the device has fp64 (all CPUs; OpenCL with cl_khr_fp64). */
VIS_INLINE int vis_triangle_intersect(const vis_ray *r, const float *v0, const float *v1,
                                      const float *v2, float *t_out)
{
    int kz = 0;
    float ax = VIS_FABSF(r->d[0]), ay = VIS_FABSF(r->d[1]), az = VIS_FABSF(r->d[2]);
    if (ay > ax && ay >= az)
        kz = 1;
    else if (az > ax && az > ay)
        kz = 2;
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    if (r->d[kz] < 0.0f) {
        int tmp = kx;
        kx = ky;
        ky = tmp;
    }
    float sx = r->d[kx] / r->d[kz];
    float sy = r->d[ky] / r->d[kz];
    float sz = 1.0f / r->d[kz];
    float A[3], B[3], C[3];
    for (int i = 0; i < 3; ++i) {
        A[i] = v0[i] - r->o[i];
        B[i] = v1[i] - r->o[i];
        C[i] = v2[i] - r->o[i];
    }
    float Ax = A[kx] - sx * A[kz], Ay = A[ky] - sy * A[kz];
    float Bx = B[kx] - sx * B[kz], By = B[ky] - sy * B[kz];
    float Cx = C[kx] - sx * C[kz], Cy = C[ky] - sy * C[kz];
    float U = Cx * By - Cy * Bx;
    float V = Ax * Cy - Ay * Cx;
    float W = Bx * Ay - By * Ax;
#if !defined(__OPENCL_VERSION__) || defined(cl_khr_fp64)
    if (U == 0.0f || V == 0.0f || W == 0.0f) {
        double CxBy = (double)Cx * (double)By, CyBx = (double)Cy * (double)Bx;
        U = (float)(CxBy - CyBx);
        double AxCy = (double)Ax * (double)Cy, AyCx = (double)Ay * (double)Cx;
        V = (float)(AxCy - AyCx);
        double BxAy = (double)Bx * (double)Ay, ByAx = (double)By * (double)Ax;
        W = (float)(BxAy - ByAx);
    }
#endif
    if ((U < 0.0f || V < 0.0f || W < 0.0f) && (U > 0.0f || V > 0.0f || W > 0.0f))
        return 0;
    float det = U + V + W;
    if (det == 0.0f)
        return 0;
    float Az = sz * A[kz], Bz = sz * B[kz], Cz = sz * C[kz];
    float T = U * Az + V * Bz + W * Cz;
    *t_out = T / det;
    return 1;
}

VIS_INLINE void vis_test_tri(const vis_ray *r, const VIS_GLOBAL vis_flat_tri *tri,
                             const VIS_GLOBAL vis_flat_object *objects, vis_hit *h)
{
    float v0[3], v1[3], v2[3], t;
    for (int i = 0; i < 3; ++i) {
        v0[i] = tri->v0[i];
        v1[i] = tri->v1[i];
        v2[i] = tri->v2[i];
    }
    if (!vis_triangle_intersect(r, v0, v1, v2, &t))
        return;
    if (!(t >= r->t_near) || t > r->t_far || t > h->t)
        return;
    vis_hit_offer_prim(t, VIS_META_OBJECT(tri->meta), 3u, VIS_META_FLAGS(tri->meta), 0.0f, objects, h);
}

/* ---- one leaf ----------------------------------------------------------------------- */

/* Distance to plane lo + k of axis a: the same expression as vis_quad_intersect. */
VIS_INLINE float vis_plane_t(const vis_ray *r, int a, float lo, int k)
{
    return ((lo + (float)k) - r->o[a]) * r->inv[a];
}

/* Clamps a float plane coordinate to [lo, hi] before the int conversion (no UB on inf).
 * The conversion truncates, which for lo >= 0 is the floor of x: the callers need no floor
 * of their own. */
VIS_INLINE int vis_clamp_plane(float x, int lo, int hi)
{
    if (!(x > (float)lo))
        return lo;
    if (x > (float)hi)
        return hi;
    return (int)x;
}

/* Where a ray crosses a plane of the leaf, on one of the plane's axes: the packed offsets
 * [c[0], c[1]] (relative to the leaf's corner lo) that a quad's edge offsets must reach for
 * vis_quad_slab to be able to take it. o is the ray's origin on that axis, td its t * d there.
 *
 * Why it is exact (never drops a quad the slab test takes): with S = |o| + |td| + |lo| + 32,
 * the float crossing p = (o + td) - lo is within 3u S of the exact one (u = 2^-24), a packed
 * edge lo + k within u (|lo| + 32) of the real lo + k, and the slab test takes a quad only
 * when the exact crossing lies within 2^-19 |td| of its edges (its entry or exit would
 * otherwise pass the plane's distance by more than vis_t_limit's slack, its own distances
 * being within 3u of exact). The margin m = 2^-16 S is more than all of these together, and
 * the floor and ceil below only widen the range. A margin that is not finite passes every
 * quad. Offsets are 0..31 (VIS_PQ_COORD_MAX): c[1] = -1 says that every quad starts past
 * the crossing, c[0] of 32 or 33 that every quad ends before it. */
VIS_INLINE float vis_crossing_margin(float o, float td_max, float lo)
{
    return (VIS_FABSF(o) + td_max + VIS_FABSF(lo) + 32.0f) * 1.52587890625e-05f; /* 2^-16 */
}

/* The range for a finite margin m: m = vis_crossing_margin(o, |td|, lo) is the margin above;
 * any larger m (the leaf walk computes one per leaf from a bound on |td| over every plane it
 * visits: each float operation is monotone) gives a superset of that range, so no quad the
 * exact test takes is dropped (docs/performance.md, "Far views at scale"). m finite makes p,
 * x and y finite; the clamps are written as selects. */
VIS_INLINE void vis_crossing_range(float o, float td, float lo, float m, int c[2])
{
    float p = (o + td) - lo;
    float x = p - m, y = p + m;
    float xc = x > 0.0f ? x : 0.0f;
    xc = xc < (float)(VIS_PQ_COORD_MAX + 1u) ? xc : (float)(VIS_PQ_COORD_MAX + 1u);
    int k = (int)xc;       /* truncation: floor, x clamped to [0, 32] */
    c[0] = k + ((float)k < x); /* ceil(x), or 0, or 33 */
    float yc = y < (float)VIS_PQ_COORD_MAX ? y : (float)VIS_PQ_COORD_MAX;
    c[1] = y >= 0.0f ? (int)yc : -1; /* floor(y) in [0, 31], or -1 */
}

/* The range with this plane's own margin (the walk's fallback where the per-leaf margin is
 * not finite); a margin that is not finite passes every quad. */
VIS_INLINE void vis_crossing_cells(float o, float td, float lo, int c[2])
{
    float m = vis_crossing_margin(o, VIS_FABSF(td), lo);
    if (!(m < VIS_INF)) {
        c[0] = 0;
        c[1] = (int)VIS_PQ_COORD_MAX;
        return;
    }
    vis_crossing_range(o, td, lo, m, c);
}

/* Whether a quad that a crossing range c (vis_crossing_range) lets through can lie in a
 * bucket whose cover mask on that axis is `mask`: such a quad has u0 <= c[1] and u1 >= c[0],
 * so its unit cells [u0, max(u0, u1 - 1)] meet [max(c[0] - 1, 0), c[1]]; an empty range lets
 * none through. */
VIS_INLINE int vis_cover_meets(uint32_t mask, const int *c)
{
    int lo = c[0] > 0 ? c[0] - 1 : 0;
    return c[1] >= lo && (mask & vis_cover_bits(lo, c[1])) != 0u;
}

/* The crossing range c on one axis of a bucket's plane (vis_crossing_range with the leaf's
 * margin m, or vis_crossing_cells where the leaf has none) and whether the bucket's cover
 * mask on that axis meets it. */
VIS_INLINE int vis_crossing_covered(float o, float td, float lo, float m, int per_bucket, uint32_t mask, int c[2])
{
    if (per_bucket)
        vis_crossing_cells(o, td, lo, c);
    else
        vis_crossing_range(o, td, lo, m, c);
    return vis_cover_meets(mask, c);
}

/* The leaf's loose quads and triangles (always tested: they are not in the content box). */
VIS_NOINLINE void vis_leaf_loose(const vis_ray *r, const VIS_GLOBAL vis_flat_leaf *leaf,
                                 const VIS_GLOBAL uint32_t *quads, const VIS_GLOBAL vis_flat_tri *tris,
                                 const VIS_GLOBAL vis_flat_object *objects, vis_hit *h)
{
    uint32_t n = leaf->loose_count;
    const VIS_GLOBAL vis_flat_quad *loose = vis_loose_quads(quads, leaf);
    for (uint32_t i = 0; i < n; ++i)
        vis_test_quad(r, loose[i], objects, h);
    n = leaf->tri_count;
    for (uint32_t i = 0; i < n; ++i)
        vis_test_tri(r, &tris[leaf->tri_offset + i], objects, h);
}

/* The plane walk of vis_leaf_intersect over [ta, tb] (already narrowed to the content box),
 * with the leaf's plane counts E and the box's offsets bl, bh (bh read as the last plane when
 * saturated). Kept out of line on the CPU so that the leaves whose box a ray misses, most of
 * those it enters, cost no call (vis_leaf_intersect inlines into every walk). */
VIS_NOINLINE void vis_leaf_planes(const vis_ray *r, const VIS_GLOBAL vis_flat_leaf *leaf,
                                  const VIS_GLOBAL uint32_t *buckets, const VIS_GLOBAL uint32_t *quads,
                                  const VIS_GLOBAL vis_flat_object *objects, float ta, float tb, const int *E,
                                  const int *bl, const int *bh, vis_hit *h)
{
    int base[3];
    base[0] = 0;
    base[1] = E[0] + 1;
    base[2] = E[0] + E[1] + 2;
    int k[3], kend[3], step[3];
    float tk[3];
    float lo[3];
    float t_abs = 0.0f; /* the largest |t| of a plane the walk can visit */
    for (int a = 0; a < 3; ++a)
        lo[a] = leaf->lo[a];
    for (int a = 0; a < 3; ++a) {
        tk[a] = VIS_INF;
        k[a] = 0;
        kend[a] = 0;
        step[a] = 0;
        if (r->d[a] == 0.0f)
            continue; /* never crosses planes of this axis */
        /* Planes crossed between ta and tb, widened against rounding in the entry/exit
         * positions: floor(x0) - 1 up to ceil(x1) + 1, or one plane more where x1 + 2 rounds
         * up to a whole number (vis_clamp_plane floors; x0 - 1 is exact in [0.5, 2^24), and
         * below 0.5 or past kh both ends clamp as floor(x0) - 1 would). The walk steps over
         * the planes outside the interval's slack (below). The range is ordered by value, so
         * the walk ends even if ta > tb by rounding. */
        float xa = (r->o[a] + ta * r->d[a]) - lo[a];
        float xb = (r->o[a] + tb * r->d[a]) - lo[a];
        float x0 = xa < xb ? xa : xb, x1 = xa < xb ? xb : xa;
        int kh = bh[a] < E[a] ? bh[a] : E[a]; /* the box may reach past the last plane */
        int kl = bl[a] < kh ? bl[a] : kh;
        int klo = vis_clamp_plane(x0 - 1.0f, kl, kh);
        int khi = vis_clamp_plane(x1 + 2.0f, kl, kh);
        if (r->d[a] > 0.0f) {
            k[a] = klo;
            kend[a] = khi;
            step[a] = 1;
        } else {
            k[a] = khi;
            kend[a] = klo;
            step[a] = -1;
        }
        tk[a] = vis_plane_t(r, a, lo[a], k[a]);
        /* Stepped over: the planes before lim^-1(ta), which hold no quad the walk must find
         * (below). */
        while (vis_t_limit(tk[a]) < ta && k[a] != kend[a]) {
            k[a] += step[a];
            tk[a] = vis_plane_t(r, a, lo[a], k[a]);
        }
        if (vis_t_limit(tk[a]) < ta) {
            tk[a] = VIS_INF;
            continue;
        }
        /* The planes' distances are monotone in k (rounding is), so the largest |t| the walk
         * can meet on this axis is at one end of its range. */
        float t_end = vis_plane_t(r, a, lo[a], kend[a]);
        float f = VIS_FABSF(tk[a]) > VIS_FABSF(t_end) ? VIS_FABSF(tk[a]) : VIS_FABSF(t_end);
        t_abs = f > t_abs ? f : t_abs;
    }
    /* The crossing ranges' margins, once per leaf (vis_crossing_range): |t d[u]| <= t_abs |d[u]|
     * for every plane visited. A margin that is not finite (or NaN, from inf * 0) takes the
     * per-bucket margin instead. */
    float mg[3];
    for (int a = 0; a < 3; ++a)
        mg[a] = vis_crossing_margin(r->o[a], t_abs * VIS_FABSF(r->d[a]), lo[a]);
    int per_bucket = !(mg[0] < VIS_INF && mg[1] < VIS_INF && mg[2] < VIS_INF);
    const VIS_GLOBAL uint32_t *packed = quads + leaf->quad_offset;
    const VIS_GLOBAL uint32_t *table = quads + leaf->table_offset;
    const VIS_GLOBAL uint32_t *bk = buckets + leaf->bucket_offset;
    const VIS_GLOBAL uint32_t *cover = bk + vis_bucket_offsets((uint32_t)E[0], (uint32_t)E[1], (uint32_t)E[2]);
    /* The quads this walk must find lie at distances t with ta <= lim(t) and t <= lim(tb)
     * (vis_leaf_intersect): planes before lim^-1(ta) were stepped over above, and a plane
     * past lim(tb) ends the walk, though the plane ranges reach a plane or two past each
     * end against the rounding of the positions they are computed from. */
    float t_stop = vis_t_limit(tb);
    t_stop = r->t_far < t_stop ? r->t_far : t_stop;
    for (;;) {
        int a = 0;
        if (tk[1] < tk[a])
            a = 1;
        if (tk[2] < tk[a])
            a = 2;
        float t = tk[a];
        /* Planes come in non-decreasing t per axis (rounding is monotone), so nothing after a
         * plane beyond the best hit can beat it; equal t is still visited for the tie rule. */
        if (t == VIS_INF || !(t <= h->t) || t > t_stop)
            break; /* every axis walked, or past the best hit / the leaf's end / far plane */
        uint32_t b = (uint32_t)(base[a] + k[a]);
        uint32_t u = a == 2 ? 0u : (uint32_t)a + 1u;
        uint32_t v = a == 0 ? 2u : (uint32_t)a - 1u;
        float lu = lo[u], lv = lo[v];
        int cu[2], cv[2];
        /* The bucket's cover masks come first, u then v: most buckets end there, an empty
         * one (masks 0) at the first word, and only the buckets they let through read their
         * offsets (one cache line, one load on a device, fewer per plane visited). */
        uint32_t mu = cover[2u * b];
        if (t >= r->t_near && mu != 0u &&
            vis_crossing_covered(r->o[u], t * r->d[u], lu, mg[u], per_bucket, mu, cu) &&
            vis_crossing_covered(r->o[v], t * r->d[v], lv, mg[v], per_bucket, cover[2u * b + 1u], cv)) {
            /* A bucket's quads are sorted by u0 (scene.c). A quad whose offsets do not reach
             * the crossing's range (vis_crossing_cells) is one the exact test would miss;
             * one whose u0 starts past it ends the bucket, as every quad after it does too. */
            for (uint32_t i = bk[b], end = bk[b + 1u]; i < end; ++i) {
                uint32_t w = packed[i];
                int u0 = (int)VIS_PQ_FIELD(w, 0u);
                if (u0 > cu[1])
                    break; /* this quad and the rest of the bucket start past the crossing */
                if ((int)VIS_PQ_FIELD(w, 2u) < cu[0] || (int)VIS_PQ_FIELD(w, 1u) > cv[1] ||
                    (int)VIS_PQ_FIELD(w, 3u) < cv[0])
                    continue;
                /* vis_test_quad, with what this walk already knows: the plane's distance t
                 * (vis_quad_intersect's t for each quad of the bucket), within [t_near,
                 * t_far] and no farther than the best hit. */
                if (!vis_quad_slab(r, u, v, t, lu + (float)u0, lv + (float)VIS_PQ_FIELD(w, 1u),
                                   lu + (float)VIS_PQ_FIELD(w, 2u), lv + (float)VIS_PQ_FIELD(w, 3u)))
                    continue;
                vis_hit_offer_prim(t, table[VIS_PQ_TABLE(w)], (uint32_t)a, VIS_PQ_FLAGS(w), lo[a] + (float)k[a], objects,
                                   h);
            }
        }
        if (k[a] == kend[a]) {
            tk[a] = VIS_INF;
        } else {
            k[a] += step[a];
            tk[a] = vis_plane_t(r, a, lo[a], k[a]);
        }
    }
}

#if VIS_LABEL_WALK
/* ---- the CPU's label walk ------------------------------------------------------------
 *
 * A leaf of one object's packed quads, 16 voxels a side, no loose quads, triangles or material
 * flags, gets from the CPU backend (backends/cpu/labels.c) two labels for its 16^3 voxels
 * such that two face-neighbours differ exactly where a quad covers the square between them,
 * and a "loud" bit for every voxel that touches a quad (its square, edge or corner). A ray
 * then walks the leaf voxel by voxel (the 3D-DDA of Amanatides & Woo 1987) instead of plane
 * by plane, and decides most crossings without reading a quad:
 *  - a crossing out of a quiet voxel meets no quad: none touches the voxel;
 *  - a crossing out of a loud voxel into a loud one, away from the square's edges, meets a
 *    quad exactly when the labels differ (the quads cover whole squares): the object is the
 *    leaf's one, the distance the plane's, computed as the quad test computes it;
 *  - every other crossing out of a loud voxel (near an edge or a corner, within the walk's
 *    slack; leaving the leaf, whose boundary planes the labels do not see) visits its bucket
 *    as the plane walk does (vis_bucket_visit).
 * The labels are the parity of the covered squares crossed from the leaf's corner; a leaf
 * whose quads admit no such parity keeps the plane walk (docs/performance.md, "The label
 * walk"). The leaf's block, in 32-bit words: L (bricks holding a loud voxel), X (of those,
 * bricks whose loud voxels hold both labels), U (the one label of every other brick of L),
 * each 64 bits over the 4^3 bricks; then a 64-bit word of loud bits per brick of L, then one of
 * labels per brick of X, in brick order. Brick j holds voxels x, y, z with j = x/4 + 4 (y/4) +
 * 16 (z/4), bit (x%4) + 4 (y%4) + 16 (z%4). */
#define VIS_LW_BRICK(b) ((((b) >> 2) & 3u) | (((b) >> 4) & 12u) | (((b) >> 6) & 48u))
#define VIS_LW_BIT(b) (((b) & 3u) | (((b) >> 2) & 12u) | (((b) >> 4) & 48u))
#define VIS_LW_HEADER 6u

VIS_INLINE vis_u64 vis_lw_u64(const uint32_t *p) { return (vis_u64)p[0] | (vis_u64)p[1] << 32; }

/* Set bits of x (SWAR: the library builds for any x86-64, without the popcnt instruction). */
VIS_INLINE uint32_t vis_popcount64(vis_u64 x)
{
    x = x - ((x >> 1) & 0x5555555555555555ull);
    x = (x & 0x3333333333333333ull) + ((x >> 2) & 0x3333333333333333ull);
    x = (x + (x >> 4)) & 0x0F0F0F0F0F0F0F0Full;
    return (uint32_t)((x * 0x0101010101010101ull) >> 56);
}

/* Leaf li's block, or NULL: labels[li] is its word offset in labels, 0 for none. */
VIS_INLINE const uint32_t *vis_leaf_labels(const uint32_t *labels, uint32_t li)
{
    return labels && labels[li] ? labels + labels[li] : (const uint32_t *)0;
}
#  define VIS_LEAF_LABELS(li) , vis_leaf_labels(labels, (li))
#  define VIS_LEAF_LABELS_PARAM , const uint32_t *lab

typedef struct vis_lw_block {
    const uint32_t *loud, *label; /* the blocks' loud and label words                         */
    vis_u64 L, X, U;
} vis_lw_block;

/* Brick j's loud bits and its labels as a word (every bit the brick's one label where it
 * has one; only the loud voxels' bits are read). Both 0 for a brick outside L. */
VIS_INLINE vis_u64 vis_lw_brick(const vis_lw_block *B, uint32_t j, vis_u64 *label)
{
    vis_u64 below = ((vis_u64)1u << j) - 1u;
    *label = 0u;
    if (!(B->L >> j & 1u))
        return 0u;
    if (B->X >> j & 1u)
        *label = vis_lw_u64(B->label + 2u * vis_popcount64(B->X & below));
    else if (B->U >> j & 1u)
        *label = ~(vis_u64)0u;
    return vis_lw_u64(B->loud + 2u * vis_popcount64(B->L & below));
}

/* The quads of bucket b (the plane `plane` of axis a, crossed at t >= t_near, t <= t_far and
 * no farther than the best hit) that the exact test takes, as vis_leaf_planes visits a
 * bucket: its cover masks first, then its quads by u0. u, v are the plane's axes, lu, lv the
 * leaf's corner on them, mu_m, mv_m the leaf's crossing margins there (per_bucket: each
 * bucket's own). vis_leaf_planes keeps its own copy of these lines inline: called from there
 * as a function, the same code made the H100's batches of 256 views 2.3-2.5 % slower
 * (docs/opencl.md, "The plane walk's bucket visit as a function"), one more value held across
 * the walk under the batch programs' register cap. */
VIS_INLINE void vis_bucket_visit(const vis_ray *r, uint32_t a, uint32_t u, uint32_t v, uint32_t b, float t, float plane,
                                 float lu, float lv, float mu_m, float mv_m, int per_bucket,
                                 const VIS_GLOBAL uint32_t *packed, const VIS_GLOBAL uint32_t *table,
                                 const VIS_GLOBAL uint32_t *bk, const VIS_GLOBAL uint32_t *cover,
                                 const VIS_GLOBAL vis_flat_object *objects, vis_hit *h)
{
    int cu[2], cv[2];
    uint32_t mu = cover[2u * b];
    if (!(mu != 0u && vis_crossing_covered(r->o[u], t * r->d[u], lu, mu_m, per_bucket, mu, cu) &&
          vis_crossing_covered(r->o[v], t * r->d[v], lv, mv_m, per_bucket, cover[2u * b + 1u], cv)))
        return;
    /* A bucket's quads are sorted by u0 (scene.c). A quad whose offsets do not reach the
     * crossing's range (vis_crossing_cells) is one the exact test would miss; one whose u0
     * starts past it ends the bucket, as every quad after it does too. */
    for (uint32_t i = bk[b], end = bk[b + 1u]; i < end; ++i) {
        uint32_t w = packed[i];
        int u0 = (int)VIS_PQ_FIELD(w, 0u);
        if (u0 > cu[1])
            break; /* this quad and the rest of the bucket start past the crossing */
        if ((int)VIS_PQ_FIELD(w, 2u) < cu[0] || (int)VIS_PQ_FIELD(w, 1u) > cv[1] || (int)VIS_PQ_FIELD(w, 3u) < cv[0])
            continue;
        /* vis_test_quad, with what the walk already knows: the plane's distance t
         * (vis_quad_intersect's t for each quad of the bucket), within [t_near, t_far] and
         * no farther than the best hit. */
        if (!vis_quad_slab(r, u, v, t, lu + (float)u0, lv + (float)VIS_PQ_FIELD(w, 1u), lu + (float)VIS_PQ_FIELD(w, 2u),
                           lv + (float)VIS_PQ_FIELD(w, 3u)))
            continue;
        vis_hit_offer_prim(t, table[VIS_PQ_TABLE(w)], a, VIS_PQ_FLAGS(w), plane, objects, h);
    }
}

/* Plane k of axis a, crossed at t, as the plane walk visits it. */
VIS_INLINE void vis_lw_visit(const vis_ray *r, const vis_flat_leaf *leaf, const uint32_t *buckets, const uint32_t *quads,
                             const vis_flat_object *objects, const float *lo, uint32_t a, int k, float t, vis_hit *h)
{
    if (!(t >= r->t_near && t <= r->t_far))
        return;
    const uint32_t *bk = buckets + leaf->bucket_offset;
    uint32_t u = a == 2u ? 0u : a + 1u, v = a == 0u ? 2u : a - 1u;
    /* per_bucket: each bucket's own margin (the leaf's, 0 here, is not read) */
    vis_bucket_visit(r, a, u, v, 17u * a + (uint32_t)k, t, lo[a] + (float)k, lo[u], lo[v], 0.0f, 0.0f, 1,
                     quads + leaf->quad_offset, quads + leaf->table_offset, bk, bk + vis_bucket_offsets(16u, 16u, 16u),
                     objects, h);
}

/* Whether the ray may take the label walk through this leaf over [ta, tb]:
 *  - not lying in one of the leaf's integer planes (its crossings there are no crossings),
 *    and inside the leaf's slab on an axis it runs parallel to;
 *  - entered by ta, by the walk's own distances: the entry plane of each other axis crossed
 *    at or before ta (the CPU's walks clip to the leaf's slabs, so they always qualify). From
 *    an interval that began before the leaf, a crossing of another axis before the entry
 *    would read the labels of a voxel the ray is not in;
 *  - the slack of a distance at the leaf's far end under half a voxel (so that "near an
 *    edge" is a neighbourhood of the edge, not of the whole voxel). */
VIS_INLINE int vis_lw_walkable(const vis_ray *r, const vis_flat_leaf *leaf, float ta, float tb)
{
    float m = 0.0f;
    for (int a = 0; a < 3; ++a) {
        float lo = leaf->lo[a];
        if (r->d[a] == 0.0f) {
            float p = r->o[a] - lo;
            if ((p >= 0.0f && p <= 16.0f && p == (float)(int)p) || !(r->o[a] >= lo && r->o[a] <= lo + 16.0f))
                return 0;
        } else if (!(vis_plane_t(r, a, lo, r->d[a] > 0.0f ? 0 : 16) <= ta)) {
            return 0;
        }
        m = VIS_FABSF(r->d[a]) > m ? VIS_FABSF(r->d[a]) : m;
    }
    return (vis_t_limit(tb) - tb) * m < 0.5f;
}

/* The label walk over [ta, tb] (vis_leaf_intersect's interval, within the content box).
 * Returns 0, having done nothing, where the plane walk must take the leaf instead. */
VIS_NOINLINE int vis_label_walk(const vis_ray *r, const vis_flat_leaf *leaf, const uint32_t *buckets,
                                const uint32_t *quads, const vis_flat_object *objects, const uint32_t *lab, float ta,
                                float tb, vis_hit *h)
{
    if (!vis_lw_walkable(r, leaf, ta, tb))
        return 0;
    float lo[3];
    for (int a = 0; a < 3; ++a)
        lo[a] = leaf->lo[a];
    vis_lw_block B;
    B.L = vis_lw_u64(lab);
    B.X = vis_lw_u64(lab + 2);
    B.U = vis_lw_u64(lab + 4);
    B.loud = lab + VIS_LW_HEADER;
    B.label = B.loud + 2u * vis_popcount64(B.L);
    const uint32_t owner = quads[leaf->table_offset];
    const float lim_b = vis_t_limit(tb);
    int ix[3], st[3], stride[3];
    float tn[3];
    for (int a = 0; a < 3; ++a) {
        float p = (r->o[a] + ta * r->d[a]) - lo[a];
        int i = vis_clamp_plane(p, 0, 15);
        st[a] = r->d[a] > 0.0f ? 1 : r->d[a] < 0.0f ? -1 : 0;
        /* The start voxel by the crossings' own distances where the rounded point lies within
         * its rounding of a voxel's side. */
        float f = p - (float)i, e = 0.0009765625f + (VIS_FABSF(r->o[a]) + VIS_FABSF(ta * r->d[a])) * 1.52587890625e-5f;
        if (!(f >= e && f <= 1.0f - e)) {
            if (st[a] > 0) {
                while (i > 0 && vis_plane_t(r, a, lo[a], i) > ta)
                    --i;
                while (i < 15 && vis_plane_t(r, a, lo[a], i + 1) <= ta)
                    ++i;
            } else if (st[a] < 0) {
                while (i < 15 && vis_plane_t(r, a, lo[a], i + 1) > ta)
                    ++i;
                while (i > 0 && vis_plane_t(r, a, lo[a], i) <= ta)
                    --i;
            }
        }
        ix[a] = i;
        tn[a] = st[a] > 0 ? vis_plane_t(r, a, lo[a], i + 1) : st[a] < 0 ? vis_plane_t(r, a, lo[a], i) : VIS_INF;
    }
    stride[0] = st[0];
    stride[1] = 16 * st[1];
    stride[2] = 256 * st[2];
    uint32_t bit = (uint32_t)ix[0] + 16u * ((uint32_t)ix[1] + 16u * (uint32_t)ix[2]);
    uint32_t j = VIS_LW_BRICK(bit);
    vis_u64 label, loud = vis_lw_brick(&B, j, &label); /* the current brick's */
    if (loud >> VIS_LW_BIT(bit) & 1u) {
        /* The plane behind the start voxel on each axis, within the slack of ta: exact. */
        for (int a = 0; a < 3; ++a) {
            if (!st[a])
                continue;
            int k = st[a] > 0 ? ix[a] : ix[a] + 1;
            float t = vis_plane_t(r, a, lo[a], k);
            if (vis_t_limit(t) >= ta && t <= lim_b && t <= h->t)
                vis_lw_visit(r, leaf, buckets, quads, objects, lo, (uint32_t)a, k, t, h);
        }
    }
    /* The walk's state in scalars, axis by axis, as the cell-grid walk keeps its own, so that
     * the compiler can keep it in registers: far passes of lone rays took 2-6 % less time at
     * the median, for 0.4-1 % more instructions (docs/performance.md, "The label walk's state
     * in scalars"). Each step takes the nearest crossing, the lowest axis where two tie. */
    float tn0 = tn[0], tn1 = tn[1], tn2 = tn[2];
    int ix0 = ix[0], ix1 = ix[1], ix2 = ix[2];
    float t_prev = ta;
    int out = 0;
    for (;;) {
        int a = tn1 < tn0 ? 1 : 0;
        float t = a ? tn1 : tn0;
        if (tn2 < t) {
            a = 2;
            t = tn2;
        }
        if (t == VIS_INF || t > lim_b || !(t <= h->t))
            return 1;
        int ia = a == 0 ? ix0 : a == 1 ? ix1 : ix2, sa = st[a];
        int next = ia + sa;
        int inside = next >= 0 && next <= 15;

        if (out || (loud >> VIS_LW_BIT(bit) & 1u)) {
            int k = sa > 0 ? ia + 1 : ia;
            float second = a == 0 ? (tn1 < tn2 ? tn1 : tn2) : a == 1 ? (tn0 < tn2 ? tn0 : tn2) : (tn0 < tn1 ? tn0 : tn1);
            if (out || !inside || t <= vis_t_limit(t_prev) || second <= vis_t_limit(t)) {
                vis_lw_visit(r, leaf, buckets, quads, objects, lo, (uint32_t)a, k, t, h);
            } else {
                /* A quad covers the square between the two voxels: both are loud, and their
                 * labels differ. */
                uint32_t nb = (uint32_t)((int)bit + stride[a]), jn = VIS_LW_BRICK(nb);
                vis_u64 nlabel = label, nloud = loud;
                if (jn != j)
                    nloud = vis_lw_brick(&B, jn, &nlabel);
                if ((nloud >> VIS_LW_BIT(nb) & 1u) && ((label >> VIS_LW_BIT(bit) ^ nlabel >> VIS_LW_BIT(nb)) & 1u) &&
                    t >= r->t_near && t <= r->t_far)
                    vis_hit_offer_prim(t, owner, (uint32_t)a, 0u, lo[a] + (float)k, objects, h);
            }
        }
        t_prev = t;
        /* Out of the leaf on this axis, its crossing is VIS_INF: the others' crossings within
         * lim(tb) still count. */
        float tnext = inside ? vis_plane_t(r, a, lo[a], sa > 0 ? next + 1 : next) : VIS_INF;
        if (a == 0) {
            ix0 = inside ? next : ix0;
            tn0 = tnext;
        } else if (a == 1) {
            ix1 = inside ? next : ix1;
            tn1 = tnext;
        } else {
            ix2 = inside ? next : ix2;
            tn2 = tnext;
        }
        if (!inside) {
            out = 1;
            continue;
        }
        bit = (uint32_t)((int)bit + stride[a]);
        if (VIS_LW_BRICK(bit) != j) {
            j = VIS_LW_BRICK(bit);
            loud = vis_lw_brick(&B, j, &label);
        }
    }
}
#else
#  define VIS_LEAF_LABELS(li)
#  define VIS_LEAF_LABELS_PARAM
#endif

/* Tests every primitive of the leaf that can beat the best hit, for the part [ta, tb] of
 * the ray inside the leaf. Hits outside [ta, tb] are real hits too and are kept: the result
 * is the minimum over all primitives tested, whatever order they come in.
 *
 * The packed quads are looked for only where the ray crosses the leaf's content box (the box
 * of every packed quad, vis_flat_leaf.content_box): the air above a terrain surface that the
 * leaf also holds, and the solid below it, which holds no face, cost no plane steps (empty
 * space skipping at the leaf's own level; Lee & Han 2005, seeds/001). [ta, tb] is narrowed by
 * vis_slab to the box's slabs, whose bounds lo + offset are computed as the quads' own
 * coordinates (vis_unpack_quad) and whose distances are computed as the quad test's.
 *
 * Why no quad the exact test takes is lost. Let a packed quad q be taken at its plane's
 * distance t (vis_quad_slab: t_in <= lim(t_out), lim = vis_t_limit, with t_in the latest
 * entry into the slabs of q's box [plane, plane] x [u0, u1] x [v0, v1] and t_out the earliest
 * exit; t itself is q's entry and exit on its own axis, so t_out <= t <= t_in). q's box lies
 * in the content box, and rounding is monotone, so on every axis the box's bound is no
 * farther in than q's (lo + k as floats, then (c - o) * inv with the same inv), the box's entry
 * no later than q's and its exit no earlier; a ray parallel to an axis lies in q's slab only
 * if it lies in the box's. Hence the box's entry T_in <= t_in <= lim(t_out) <= lim(t), and
 * t <= t_in <= lim(t_out) <= lim(T_out). The narrowed interval [max(ta, T_in), min(tb, T_out)]
 * therefore keeps, for every such quad, whatever the caller's [ta, tb] gave: its start moves
 * only to a distance within the slack of t, its end likewise, so the plane range below
 * (widened by one plane on each side against exactly such rounding, as it is for the leaf's
 * own entry and exit) still holds q's plane. The walks hand a leaf an interval that holds the
 * distance t of every quad it must find within the same slack (ta <= lim(t), t <= lim(tb):
 * their intervals are the leaf's slab test, docs/traversal.md "Exactness"), so when the
 * narrowed start lies beyond lim(lim(end)) no such quad exists and the walk returns at once.
 * The plane range of each axis is also kept inside the box's offsets on that axis, where all
 * the non-empty buckets of that axis lie. */
VIS_INLINE void vis_leaf_intersect(const vis_ray *r, const VIS_GLOBAL vis_flat_leaf *leaf,
                                   const VIS_GLOBAL uint32_t *buckets,
                                   const VIS_GLOBAL uint32_t *quads,
                                   const VIS_GLOBAL vis_flat_tri *tris,
                                   const VIS_GLOBAL vis_flat_object *objects VIS_LEAF_LABELS_PARAM, float ta,
                                   float tb, vis_hit *h)
{
    if (leaf->loose_count | leaf->tri_count)
        vis_leaf_loose(r, leaf, quads, tris, objects, h);
    if (leaf->quad_count == 0u)
        return;
    int E[3];
    E[0] = (int)(leaf->dims_xy & 0xFFFFu);
    E[1] = (int)(leaf->dims_xy >> 16);
    E[2] = (int)leaf->dims_z;
    int bl[3], bh[3];
    uint32_t cb = leaf->content_box;
    /* The vertical axis (y) first: in a terrain or a city most leaves a ray enters and whose
     * box it misses it passes above (docs/performance.md, "Lone rays"), so the walk usually
     * returns after one slab. Every narrowing only moves ta up and tb down and vis_t_limit is
     * monotone, so a test after any axis rejects only what the test after all three would. */
    for (int i = 0; i < 3; ++i) {
        int a = i == 0 ? 1 : i == 1 ? 0 : 2;
        bl[a] = (int)VIS_BOX_FIELD(cb, (uint32_t)a);
        bh[a] = (int)VIS_BOX_FIELD(cb, (uint32_t)a + 3u);
        if (bh[a] == (int)VIS_PQ_COORD_MAX && E[a] > bh[a])
            bh[a] = E[a]; /* saturated: a plane may lie up to the leaf's last one */
        /* A box that spans the whole leaf on this axis narrows nothing the walks' own
         * interval (the leaf's slab) had not: its slab is skipped. [ta, tb] then stays a
         * superset of the narrowed interval, which loses no quad (the argument above) and
         * only rejects less; at street level in a city, leaves full of walls, the clip cost
         * 8.8-9.5 % (docs/performance.md, "The per-ray leaf walk clips the ray"). */
        if (bl[a] == 0 && bh[a] >= E[a])
            continue;
        float lo = leaf->lo[a];
        if (!vis_slab(r, (uint32_t)a, lo + (float)bl[a], lo + (float)bh[a], &ta, &tb) ||
            ta > vis_t_limit(vis_t_limit(tb)))
            return; /* parallel to the axis outside the box's slab, or the box is missed */
    }
#if VIS_LABEL_WALK && !defined(VIS_TRACE_EFFECTS)
    if (lab && vis_label_walk(r, leaf, buckets, quads, objects, lab, ta, tb, h))
        return;
#elif VIS_LABEL_WALK
    (void)lab; /* the effects pass offers every plane's quads: it walks planes */
#endif
    vis_leaf_planes(r, leaf, buckets, quads, objects, ta, tb, E, bl, bh, h);
}

/* ---- traversal ---------------------------------------------------------------------- */

/* Termination: a node is skipped only when it starts beyond the best hit by more than
 * vis_t_limit's slack (the quad test and the walk's decisions use the same). */

/* Clips the ray to the scene box [0, size] (closed, with the same slack). */
VIS_INLINE int vis_clip_scene(const vis_ray *r, const float *size, float *t0, float *t1)
{
    float a = r->t_near, b = r->t_far;
    for (int i = 0; i < 3; ++i) {
        if (r->d[i] == 0.0f) {
            if (r->o[i] < 0.0f || r->o[i] > size[i])
                return 0;
            continue;
        }
        float ta = (0.0f - r->o[i]) * r->inv[i];
        float tb = (size[i] - r->o[i]) * r->inv[i];
        if (ta > tb) {
            float tmp = ta;
            ta = tb;
            tb = tmp;
        }
        if (ta > a)
            a = ta;
        if (tb < b)
            b = tb;
    }
    if (a > vis_t_limit(b))
        return 0;
    *t0 = a;
    *t1 = b;
    return 1;
}

/* The child a ray meets first: the side of the split plane its origin lies on; an origin on
 * the plane moves into the side its direction points to (the lower child for d < 0). The
 * same rule in every traversal keeps their leaf orders identical. */
VIS_INLINE uint32_t vis_near_child(float o, float d, float split, uint32_t first)
{
    return o < split || (o == split && d < 0.0f) ? first : first + 1u;
}

/* What the stack method does at an inner node (after Havran's TA_B cases), shared by every
 * traversal so that they all visit the same leaves with the same intervals. */
#define VIS_GO_NEAR 0
#define VIS_GO_FAR 1
#define VIS_GO_BOTH 2          /* near over [t_min, min(*t_split, t_max)], far from there to t_max */
#define VIS_GO_BOTH_IN_PLANE 3 /* a ray lying in the split plane: both over [t_min, t_max]      */

VIS_INLINE int vis_node_decide(const vis_ray *r, uint32_t a, float split, uint32_t first, float t_min,
                               float t_max, uint32_t *near_out, uint32_t *far_out, float *t_split_out)
{
    float o = r->o[a], d = r->d[a];
    uint32_t near_child = vis_near_child(o, d, split, first);
    *near_out = near_child;
    *far_out = near_child == first ? first + 1u : first;
    if (d == 0.0f)
        return o == split ? VIS_GO_BOTH_IN_PLANE : VIS_GO_NEAR;
    float t_split = (split - o) * r->inv[a];
    *t_split_out = t_split;
    /* A ray that starts on the plane at distance 0 (a secondary ray leaving a surface: t_near
     * is 0) touches the child behind it there, and a quad of that child through the origin is
     * hit at t = 0, as the brute force finds it (t >= t_near): both, the child behind over
     * [0, 0] first. Primary rays start at t_near > 0 and never take this. */
    if (t_split == 0.0f && t_min <= 0.0f) {
        *near_out = *far_out;
        *far_out = near_child;
        *t_split_out = 0.0f;
        return VIS_GO_BOTH;
    }
    /* t_split <= 0: the ray starts on or past the plane and moves into near_child. Otherwise
     * a child is entered when the ray's part in it is non-empty within vis_t_limit's slack:
     * far when t_split <= lim(t_max), near when t_min <= lim(t_split). A leaf is thus entered
     * exactly when its box passes the slab test with that slack (the latest entry distance
     * no later than lim of the earliest exit, pair by pair down the path), the test that
     * vis_quad_intersect makes of each quad's box inside it. */
    if (t_split <= 0.0f || t_split > vis_t_limit(t_max))
        return VIS_GO_NEAR;
    if (t_min > vis_t_limit(t_split))
        return VIS_GO_FAR;
    return VIS_GO_BOTH;
}

#define VIS_STACK_SIZE 64
#define VIS_STACK_SAME_INTERVAL 0x80000000u

typedef struct vis_stack_entry {
    uint32_t node;
    float t_max;
} vis_stack_entry;

/* One step down from inner node `node` for the stack methods: the child to enter next, the
 * far child pushed when both are crossed (flagged, with its t_min, for a ray lying in the
 * split plane: its t_max is where the near subtree ends, the current t_max when popped). A
 * full stack (capacity > depth) never drops a push. */
VIS_INLINE uint32_t vis_descend(const vis_ray *r, const VIS_GLOBAL vis_kd_node *nodes, uint32_t node, uint32_t info,
                                float *t_min, float *t_max, vis_stack_entry *stack, int *sp, int capacity)
{
    uint32_t near_child, far_child;
    float t_split = 0.0f;
    int go = vis_node_decide(r, info & 3u, nodes[node].split, info >> 2, *t_min, *t_max, &near_child, &far_child,
                             &t_split);
    if (go == VIS_GO_NEAR)
        return near_child;
    if (go == VIS_GO_FAR)
        return far_child;
    if (*sp < capacity) {
        stack[*sp].node = go == VIS_GO_BOTH_IN_PLANE ? far_child | VIS_STACK_SAME_INTERVAL : far_child;
        stack[*sp].t_max = go == VIS_GO_BOTH_IN_PLANE ? *t_min : *t_max;
        ++*sp;
    }
    if (go == VIS_GO_BOTH && t_split < *t_max)
        *t_max = t_split;
    return near_child;
}

/* Front-to-back traversal with a full stack of 8-byte entries (Chang & Ihm 2010, "stack").
 * A ray lying exactly in a split plane visits both children.
 *
 * Entries come off the stack in increasing t_min, so the first one that starts beyond the best
 * hit ends the ray -- except for the far side of an in-plane node, which starts where the near
 * side started and lies below entries that start later. So before ending the ray, the stack is
 * searched for such an entry (once per ray at most, off the hot path); the entries above it
 * all start beyond the best hit and are dropped. */
VIS_INLINE void vis_traverse_stack(const vis_ray *r, const vis_ray_setup *s, VIS_SCENE_PARAMS, vis_hit *h)
{
    float t_min, t_max;
    if (!vis_clip_scene(r, s->size, &t_min, &t_max))
        return;
    vis_stack_entry stack[VIS_STACK_SIZE];
    int sp = 0;
    uint32_t node = s->root;
    for (;;) {
        uint32_t info = nodes[node].info;
        while ((info & 3u) != VIS_NODE_LEAF) {
            node = vis_descend(r, nodes, node, info, &t_min, &t_max, stack, &sp, VIS_STACK_SIZE);
            info = nodes[node].info;
        }
        vis_leaf_intersect(r, &leaves[info >> 2], buckets, quads, tris, objects VIS_LEAF_LABELS(info >> 2), t_min,
                           t_max, h);
        if (sp == 0)
            return;
        --sp;
        node = stack[sp].node;
        if (node & VIS_STACK_SAME_INTERVAL) {
            node &= ~VIS_STACK_SAME_INTERVAL;
            t_min = stack[sp].t_max; /* saved t_min; t_max stays */
        } else {
            t_min = t_max;
            t_max = stack[sp].t_max;
        }
        if (t_min > vis_t_limit(h->t)) {
            /* Past the best hit: done, unless an in-plane far side is still below. Its near side
             * ends where the entry just above it ends (or, with none between, where the one
             * just popped does). */
            for (;;) {
                int k = sp - 1;
                while (k >= 0 && !(stack[k].node & VIS_STACK_SAME_INTERVAL))
                    --k;
                if (k < 0)
                    return;
                if (k + 1 < sp)
                    t_max = stack[k + 1].t_max;
                sp = k;
                node = stack[k].node & ~VIS_STACK_SAME_INTERVAL;
                t_min = stack[k].t_max;
                if (!(t_min > vis_t_limit(h->t)))
                    break;
            }
        }
    }
}

/* The reference: every primitive of every leaf, no tree, no ordering. */
VIS_INLINE void vis_traverse_bruteforce(const vis_ray *r, const vis_ray_setup *s, VIS_SCENE_PARAMS,
                                        vis_hit *h)
{
    for (uint32_t l = 0; l < s->leaf_count; ++l) {
        const VIS_GLOBAL vis_flat_leaf *leaf = &leaves[l];
        if (leaf->quad_count) {
            const VIS_GLOBAL uint32_t *bk = buckets + leaf->bucket_offset;
            uint32_t E[3];
            E[0] = leaf->dims_xy & 0xFFFFu;
            E[1] = leaf->dims_xy >> 16;
            E[2] = leaf->dims_z;
            uint32_t b = 0;
            for (uint32_t a = 0; a < 3u; ++a)
                for (uint32_t k = 0; k <= E[a]; ++k, ++b)
                    for (uint32_t i = bk[b]; i < bk[b + 1u]; ++i) {
                        vis_flat_quad q = vis_unpack_quad(quads[leaf->quad_offset + i], a, (int)k, leaf, quads);
                        vis_test_quad(r, q, objects, h);
                    }
        }
        const VIS_GLOBAL vis_flat_quad *loose = vis_loose_quads(quads, leaf);
        for (uint32_t i = 0; i < leaf->loose_count; ++i)
            vis_test_quad(r, loose[i], objects, h);
        for (uint32_t i = 0; i < leaf->tri_count; ++i)
            vis_test_tri(r, &tris[leaf->tri_offset + i], objects, h);
    }
}

/* ---- stackless and short-stack methods (Chang & Ihm 2010, sections 2-3) ------------------
 *
 * Every method below visits the leaves that vis_traverse_stack visits, in the same order and
 * with the same [t_min, t_max], so each primitive is tested with the same arithmetic and the
 * buffers are bit-identical. Only where that cannot be shown from the ropes alone (a ray that
 * leaves a node exactly through an edge or corner, or lies in one of its faces) does a rope
 * walk hand the rest of the ray to the restart loop, which then visits a superset: the same
 * leaves, plus some leaves it only touches at the hand-over point, with wider intervals.
 * More leaves can only add real primitives to the minimum, and the termination test is the
 * stack's, so the nearest hit is unchanged. */

/* Index of the highest set bit of m (m != 0). */
VIS_INLINE uint32_t vis_top_bit(vis_u64 m)
{
#if defined(__OPENCL_VERSION__)
    return 63u - (uint32_t)clz(m);
#elif defined(__GNUC__)
    return 63u - (uint32_t)__builtin_clzll((unsigned long long)m);
#else
    uint32_t b = 0u;
    while (m >>= 1)
        ++b;
    return b;
#endif
}

/* kd-restart (Foley & Sugerman 2005), pushdown (Horn et al. 2007) and restart with a short
 * ring stack of ring_n <= VIS_MAX_SHORT_STACK entries (Horn et al. 2007), over [t_min, t_max]
 * from node `root`.
 *
 * Plain kd-restart only keeps t_min, which is not enough to be exact: a node that the stack
 * method enters with an empty interval [t, t] (the ray passes through an edge or corner of
 * it) would be entered again after every restart, and a ray lying in a split plane needs the
 * far side with the *same* interval as the near side. So besides t_min the ray keeps a
 * restart trail (Laine 2010, "Restart trail for stackless BVH traversal"), two 64-bit masks
 * over tree levels: `pending` marks the levels where the descent went to the near child and
 * the far child is still to come (what the stack would hold), `trail` the levels whose near
 * child is finished. A restart takes the far child wherever the trail says so, which
 * reproduces the stack method's order exactly; the t_min of an in-plane node (at most one per
 * zero direction component on any path, since a descendant never splits on the same plane) is
 * kept aside to restore it, as the stack's flagged entry does.
 *
 * pushdown: restart from the deepest node above which nothing is pending instead of the root.
 * Short stack: far children also go to a ring of ring_n entries (overwriting the oldest);
 * they are popped while it lasts, and when it is empty the ray restarts. */
VIS_INLINE void vis_traverse_restart_range(const vis_ray *r, uint32_t root, float t_min, float t_max, uint32_t ring_n,
                                           int pushdown, VIS_SCENE_PARAMS, vis_hit *h)
{
    vis_stack_entry ring[VIS_MAX_SHORT_STACK];
    uint32_t top = 0u, count = 0u;
    vis_u64 trail = 0u, pending = 0u, inplane = 0u;
    float ip_t[2];
    uint32_t ip_n = 0u;
    if (ring_n > VIS_MAX_SHORT_STACK)
        ring_n = VIS_MAX_SHORT_STACK;
    uint32_t start = root, start_level = 0u;
    float start_t_max = t_max;
    uint32_t node = root, level = 0u;
    ip_t[0] = ip_t[1] = t_min;
    for (;;) {
        uint32_t info = nodes[node].info;
        while ((info & 3u) != VIS_NODE_LEAF) {
            /* The stack method's decisions, verbatim. */
            uint32_t near_child, far_child;
            float t_split = 0.0f;
            int go = vis_node_decide(r, info & 3u, nodes[node].split, info >> 2, t_min, t_max, &near_child,
                                     &far_child, &t_split);
            int in_plane = go == VIS_GO_BOTH_IN_PLANE;
            int both = go >= VIS_GO_BOTH;
            node = go == VIS_GO_FAR ? far_child : near_child;
            if (both) {
                vis_u64 bit = (vis_u64)1u << level;
                if (trail & bit) {
                    node = far_child; /* near side done; t_min is already where it ends */
                } else {
                    if (!(pending & bit)) {
                        pending |= bit;
                        if (in_plane) {
                            inplane |= bit;
                            if (ip_n < 2u)
                                ip_t[ip_n++] = t_min;
                        }
                    }
                    if (ring_n) {
                        ring[top].node = far_child;
                        ring[top].t_max = t_max;
                        top = top + 1u == ring_n ? 0u : top + 1u;
                        if (count < ring_n)
                            ++count;
                    }
                    node = near_child;
                    if (!in_plane && t_split < t_max)
                        t_max = t_split;
                }
            }
            ++level;
            if (pushdown && pending == 0u) {
                start = node;
                start_level = level;
                start_t_max = t_max;
            }
            info = nodes[node].info;
        }
        vis_leaf_intersect(r, &leaves[info >> 2], buckets, quads, tris, objects VIS_LEAF_LABELS(info >> 2), t_min,
                           t_max, h);
        for (;;) {
            if (pending == 0u)
                return;
            /* "Pop": the deepest pending level; its near side is now finished. */
            uint32_t l = vis_top_bit(pending);
            vis_u64 bit = (vis_u64)1u << l;
            pending &= ~bit;
            trail = (trail & (bit - 1u)) | bit;
            float next_t_min = t_max;
            if (inplane & bit) {
                inplane &= ~bit;
                if (ip_n > 0u)
                    next_t_min = ip_t[--ip_n];
            }
            if (count > 0u) {
                top = top == 0u ? ring_n - 1u : top - 1u;
                --count;
                node = ring[top].node;
                t_max = ring[top].t_max;
                level = l + 1u;
                if (pushdown && pending == 0u) {
                    start = node;
                    start_level = level;
                    start_t_max = t_max;
                }
            } else {
                node = start;
                level = start_level;
                t_max = start_t_max;
            }
            t_min = next_t_min;
            if (!(t_min > vis_t_limit(h->t)))
                break;
            if (inplane == 0u)
                return;
            /* Beyond the best hit, but an in-plane far side (which starts earlier) is still
             * pending, as in vis_traverse_stack: the levels below the deepest one lie in its
             * near side and start later still, so drop them and pop it. */
            uint32_t l_ip = vis_top_bit(inplane);
            while (vis_top_bit(pending) > l_ip) {
                pending &= ~((vis_u64)1u << vis_top_bit(pending));
                if (count > 0u) {
                    top = top == 0u ? ring_n - 1u : top - 1u;
                    --count;
                }
            }
        }
    }
}

VIS_INLINE void vis_traverse_restart(const vis_ray *r, const vis_ray_setup *s, uint32_t ring_n, int pushdown,
                                     VIS_SCENE_PARAMS, vis_hit *h)
{
    float t_min, t_max;
    if (!vis_clip_scene(r, s->size, &t_min, &t_max))
        return;
    vis_traverse_restart_range(r, s->root, t_min, t_max, ring_n, pushdown, VIS_SCENE_ARGS, h);
}

/* The stack method over one subtree and interval (the short stack of ropes-shortstack: a
 * subtree at most VIS_MAX_SHORT_STACK levels high never needs more entries). Returns 1 when
 * the ray is finished (the next node starts beyond the best hit). */
VIS_INLINE int vis_traverse_subtree(const vis_ray *r, uint32_t node, float t_min, float t_max, VIS_SCENE_PARAMS,
                                    vis_hit *h)
{
    vis_stack_entry stack[VIS_MAX_SHORT_STACK];
    int sp = 0;
    for (;;) {
        uint32_t info = nodes[node].info;
        while ((info & 3u) != VIS_NODE_LEAF) {
            node = vis_descend(r, nodes, node, info, &t_min, &t_max, stack, &sp, (int)VIS_MAX_SHORT_STACK);
            info = nodes[node].info;
        }
        vis_leaf_intersect(r, &leaves[info >> 2], buckets, quads, tris, objects VIS_LEAF_LABELS(info >> 2), t_min,
                           t_max, h);
        if (sp == 0)
            return 0;
        --sp;
        node = stack[sp].node;
        if (node & VIS_STACK_SAME_INTERVAL) {
            node &= ~VIS_STACK_SAME_INTERVAL;
            t_min = stack[sp].t_max;
        } else {
            t_min = t_max;
            t_max = stack[sp].t_max;
        }
        if (t_min > vis_t_limit(h->t)) {
            for (;;) { /* as in vis_traverse_stack */
                int k = sp - 1;
                while (k >= 0 && !(stack[k].node & VIS_STACK_SAME_INTERVAL))
                    --k;
                if (k < 0)
                    return 1;
                if (k + 1 < sp)
                    t_max = stack[k + 1].t_max;
                sp = k;
                node = stack[k].node & ~VIS_STACK_SAME_INTERVAL;
                t_min = stack[k].t_max;
                if (!(t_min > vis_t_limit(h->t)))
                    break;
            }
        }
    }
}

/* Ropes (Popov et al. 2007) with n = 0; ropes + short stack (Chang & Ihm 2010) with n >= 1.
 *
 * The ray works through "regions": leaves (n = 0), or the highest nodes at most n levels above
 * the leaves, whose subtree it walks with the stack method. Entering a region at t = b, it
 * takes the region's exit distance e (the smallest face distance, computed by the same
 * expression as the stack method's t_split of that plane, so e equals the t_max the stack
 * method would have), walks it over [b, e], and follows the rope of the exit face to the node
 * across, descending to the region that holds the ray just after e by comparing e with each
 * split's distance.
 *
 * That is exactly the stack method's sequence as long as every plane crossing is strict --
 * clear of the others by more than vis_t_limit's slack, with which the stack method enters a
 * node. It is not when the ray enters a region through several faces at once, leaves through
 * an edge or corner (two exit distances within the slack), meets a split plane within the
 * slack of the distance it enters at (the stack method then visits a leaf with an empty
 * interval as well), or lies in a face of the region (the stack method walks both sides).
 * Each of these is detected, on computed distances, and the rest of the ray [b, t_max] goes
 * to vis_traverse_restart_range from the root (with the same short stack): exact, and rare. */
VIS_INLINE void vis_traverse_ropes(const vis_ray *r, const vis_ray_setup *s, uint32_t n, VIS_SCENE_PARAMS, vis_hit *h)
{
    float t0, t1;
    if (!vis_clip_scene(r, s->size, &t0, &t1))
        return;
    float b = t0;
    uint32_t came = 3u; /* axis of the face the ray came in through; 3: the scene entry */
    uint32_t node = s->root;
    for (;;) {
        /* Down to the region holding the ray just after b. */
        int degenerate = 0;
        uint32_t entry = VIS_NO_ROPE;
        for (;;) {
            uint32_t info = nodes[node].info;
            if ((info & 3u) == VIS_NODE_LEAF) {
                entry = info >> 2;
                break;
            }
            if (n != 0u) {
                uint32_t e = rope_index[node];
                if (e != VIS_NO_ROPE && ropes[e].height <= n) {
                    entry = e;
                    break;
                }
            }
            uint32_t a = info & 3u;
            float split = nodes[node].split;
            float o = r->o[a], d = r->d[a];
            uint32_t side;
            if (d == 0.0f) {
                if (o == split) {
                    degenerate = 1; /* lying in the split plane */
                    break;
                }
                side = o < split ? 0u : 1u;
            } else {
                float t_split = (split - o) * r->inv[a];
                if (vis_t_tie(t_split, b)) {
                    degenerate = 1; /* meets the plane where it enters (within the slack) */
                    break;
                }
                side = (b < t_split) == (d > 0.0f) ? 0u : 1u;
            }
            node = (info >> 2) + side;
        }
        const VIS_GLOBAL vis_rope_node *rn = &ropes[entry];
        /* The region's slab distances. */
        float e = VIS_INF, t_exit[3];
        uint32_t exit_face = 6u;
        int exit_tie = 0, exit_inside = 0, inside[3];
        for (uint32_t a = 0u; a < 3u; ++a) {
            t_exit[a] = VIS_INF;
            inside[a] = 0;
        }
        for (uint32_t a = 0u; a < 3u && !degenerate; ++a) {
            float lo = rn->lo[a], hi = rn->hi[a];
            float o = r->o[a], d = r->d[a];
            if (d == 0.0f) {
                if (!(o > lo && o < hi))
                    degenerate = 1; /* lying in a face */
                continue;
            }
            float t_lo = (lo - o) * r->inv[a], t_hi = (hi - o) * r->inv[a];
            float t_in = d > 0.0f ? t_lo : t_hi, t_out = d > 0.0f ? t_hi : t_lo;
            float c_in = d > 0.0f ? lo : hi, c_out = d > 0.0f ? hi : lo;
            /* Entered through this face too, within the slack (or the distances disagree):
             * only the face it came through, or the scene's own boundary, may start at b. */
            if (t_in > b || (b <= vis_t_limit(t_in) && a != came && c_in != 0.0f && c_in != s->size[a]))
                degenerate = 1;
            t_exit[a] = t_out;
            inside[a] = c_out != 0.0f && c_out != s->size[a];
            if (t_out < e) {
                e = t_out;
                exit_face = 2u * a + (d > 0.0f ? 1u : 0u);
            }
        }
        /* Out through an edge or corner: another face within the slack of the exit. */
        for (uint32_t a = 0u; a < 3u; ++a)
            if (t_exit[a] <= vis_t_limit(e)) {
                exit_tie |= a != exit_face >> 1;
                exit_inside |= inside[a];
            }
        if (degenerate || !(e > b)) {
            vis_traverse_restart_range(r, s->root, b, t1, n, 0, VIS_SCENE_ARGS, h);
            return;
        }
        /* The last region: it ends past the ray's end by more than the slack, or at the scene's
         * boundary. (Within the slack of t1 through an inner face, the region across is next;
         * it finds itself entered past b and hands over to the restart loop.) */
        int last = e > vis_t_limit(t1) || (e >= t1 && !exit_inside);
        float t_end = e < t1 ? e : t1;
        if (n == 0u || rn->height == 0u) {
            uint32_t li = n == 0u ? entry : nodes[rn->node].info >> 2;
            vis_leaf_intersect(r, &leaves[li], buckets, quads, tris, objects VIS_LEAF_LABELS(li), b, t_end, h);
        } else if (vis_traverse_subtree(r, rn->node, b, t_end, VIS_SCENE_ARGS, h)) {
            return;
        }
        if (last || t_end > vis_t_limit(h->t))
            return;
        if (exit_tie) {
            /* Out through an edge or corner. */
            vis_traverse_restart_range(r, s->root, t_end, t1, n, 0, VIS_SCENE_ARGS, h);
            return;
        }
        node = rn->link[exit_face];
        if (node == VIS_NO_ROPE)
            return;
        b = t_end;
        came = exit_face >> 1;
    }
}

/* Leaf-ID mode: the leaf, among those holding the hit object, whose box contains the hit
 * point (the lowest such leaf; the object's first leaf if rounding puts the point in none).
 * A chunk object lies in exactly one leaf, so for chunks this is simply its leaf. */
VIS_INLINE uint32_t vis_hit_leaf_id(const vis_ray *r, const vis_hit *h, VIS_SCENE_PARAMS)
{
    const VIS_GLOBAL vis_flat_object *ob = &objects[h->object];
    uint32_t first = object_leaves[ob->leaf_offset];
    if (ob->leaf_count == 1u)
        return first + 1u;
    float p[3];
    for (int a = 0; a < 3; ++a)
        p[a] = r->o[a] + h->t * r->d[a];
    for (uint32_t i = 0; i < ob->leaf_count; ++i) {
        uint32_t l = object_leaves[ob->leaf_offset + i];
        const VIS_GLOBAL vis_flat_leaf *lf = &leaves[l];
        if (p[0] >= lf->lo[0] && p[0] <= lf->hi[0] && p[1] >= lf->lo[1] && p[1] <= lf->hi[1] &&
            p[2] >= lf->lo[2] && p[2] <= lf->hi[2])
            return l + 1u;
    }
    return first + 1u;
}

#define VIS_TRAVERSAL_ID_STACK 0u
#define VIS_TRAVERSAL_ID_BRUTEFORCE 1u
#define VIS_TRAVERSAL_ID_RESTART 2u
#define VIS_TRAVERSAL_ID_PUSHDOWN 3u
#define VIS_TRAVERSAL_ID_SHORTSTACK 4u
#define VIS_TRAVERSAL_ID_ROPES 5u
#define VIS_TRAVERSAL_ID_ROPES_SHORTSTACK 6u
#define VIS_TRAVERSAL_ID_PACKET 7u /* CPU backend only: tiles as packets (backends/cpu/packet.c) */

#define VIS_TRAVERSAL_ID_CACHED_STACK 8u
#define VIS_TRAVERSAL_ID_DDA 9u /* the cell-grid walk (vis_traverse_dda) */

/* Address space of the cached stack's ring: the work-group's local memory on a device (the
 * kernel hands each work-item its slice), the caller's own array on the CPU. */
#ifdef __OPENCL_VERSION__
#  define VIS_RING_SPACE __local
#else
#  define VIS_RING_SPACE
#endif

/* The cached stack of Chang & Ihm 2010, section 3.1: the stack method's stack split in two.
 * The top ring_n entries live in a ring (on a GPU in shared/local memory, fast); a push onto
 * a full ring first moves its oldest entry to the backing stack (private memory, which the
 * GPU keeps in its slow per-thread "local" memory), a pop takes from the ring while it holds
 * entries and from the backing stack after. Nothing is refilled: the paper's Table 1 shows
 * that with a ring of a few entries nearly every pop finds its entry there.
 *
 * The entries and their order are those of vis_traverse_stack, only stored elsewhere, so
 * the walk is the stack method's, decision for decision (vis_node_decide), and its buffers
 * are the stack method's bit for bit. Entry k of the whole stack (0 = bottom) is backing[k]
 * for k < nb, else ring[(top + ring_n - (nb + nc - k)) % ring_n]; the in-plane search of the
 * stack method reads entries below the top through vis_cached_entry. */
typedef struct vis_cached_stack {
    VIS_RING_SPACE vis_stack_entry *ring;
    uint32_t ring_n;        /* 1..VIS_MAX_SHORT_STACK                                         */
    uint32_t top;           /* ring slot the next push writes                                 */
    uint32_t nc;            /* entries in the ring                                            */
    uint32_t nb;            /* entries in the backing stack                                   */
    uint32_t stride;        /* ring slot j is ring[j * stride] (work-items interleaved in local
                               memory, so a warp's accesses fall in different banks)         */
} vis_cached_stack;

VIS_INLINE void vis_cached_push(vis_cached_stack *cs, vis_stack_entry *backing, uint32_t node, float t_max)
{
    if (cs->nc == cs->ring_n) {
        /* The ring is full: its oldest entry sits in the slot the push writes. */
        if (cs->nb < (uint32_t)VIS_STACK_SIZE)
            backing[cs->nb++] = cs->ring[cs->top * cs->stride];
    } else {
        ++cs->nc;
    }
    cs->ring[cs->top * cs->stride].node = node;
    cs->ring[cs->top * cs->stride].t_max = t_max;
    cs->top = cs->top + 1u == cs->ring_n ? 0u : cs->top + 1u;
}

VIS_INLINE vis_stack_entry vis_cached_pop(vis_cached_stack *cs, const vis_stack_entry *backing)
{
    if (cs->nc > 0u) {
        cs->top = cs->top == 0u ? cs->ring_n - 1u : cs->top - 1u;
        --cs->nc;
        return cs->ring[cs->top * cs->stride];
    }
    return backing[--cs->nb];
}

/* Entry k (0 = bottom) of the whole stack, k < nb + nc. */
VIS_INLINE vis_stack_entry vis_cached_entry(const vis_cached_stack *cs, const vis_stack_entry *backing, uint32_t k)
{
    if (k < cs->nb)
        return backing[k];
    uint32_t back = cs->nb + cs->nc - k; /* 1 = the top entry */
    return cs->ring[(cs->top + cs->ring_n - back) % cs->ring_n * cs->stride];
}

/* Drops every entry from k up (k <= nb + nc). */
VIS_INLINE void vis_cached_truncate(vis_cached_stack *cs, uint32_t k)
{
    if (k < cs->nb) {
        cs->nb = k;
        cs->top = (cs->top + cs->ring_n - cs->nc) % cs->ring_n;
        cs->nc = 0u;
    } else {
        uint32_t drop = cs->nb + cs->nc - k;
        cs->top = (cs->top + cs->ring_n - drop) % cs->ring_n;
        cs->nc -= drop;
    }
}

/* vis_traverse_stack with its stack cached (above); the ray's ring slot j is ring[j * stride],
 * j < ring_n. */
VIS_INLINE void vis_traverse_cached_stack(const vis_ray *r, const vis_ray_setup *s, VIS_RING_SPACE vis_stack_entry *ring,
                                          uint32_t stride, uint32_t ring_n, VIS_SCENE_PARAMS, vis_hit *h)
{
    float t_min, t_max;
    if (!vis_clip_scene(r, s->size, &t_min, &t_max))
        return;
    vis_stack_entry backing[VIS_STACK_SIZE];
    vis_cached_stack cs;
    cs.ring = ring;
    cs.ring_n = ring_n < 1u ? 1u : ring_n > VIS_MAX_SHORT_STACK ? VIS_MAX_SHORT_STACK : ring_n;
    cs.top = cs.nc = cs.nb = 0u;
    cs.stride = stride;
    uint32_t node = s->root;
    for (;;) {
        uint32_t info = nodes[node].info;
        while ((info & 3u) != VIS_NODE_LEAF) {
            /* vis_descend, pushing onto the cached stack (a full stack never drops a push). */
            uint32_t near_child, far_child;
            float t_split = 0.0f;
            int go = vis_node_decide(r, info & 3u, nodes[node].split, info >> 2, t_min, t_max, &near_child,
                                     &far_child, &t_split);
            if (go == VIS_GO_NEAR) {
                node = near_child;
            } else if (go == VIS_GO_FAR) {
                node = far_child;
            } else {
                if (cs.nb + cs.nc < (uint32_t)VIS_STACK_SIZE)
                    vis_cached_push(&cs, backing,
                                    go == VIS_GO_BOTH_IN_PLANE ? far_child | VIS_STACK_SAME_INTERVAL : far_child,
                                    go == VIS_GO_BOTH_IN_PLANE ? t_min : t_max);
                if (go == VIS_GO_BOTH && t_split < t_max)
                    t_max = t_split;
                node = near_child;
            }
            info = nodes[node].info;
        }
        vis_leaf_intersect(r, &leaves[info >> 2], buckets, quads, tris, objects VIS_LEAF_LABELS(info >> 2), t_min,
                           t_max, h);
        if (cs.nb + cs.nc == 0u)
            return;
        vis_stack_entry e = vis_cached_pop(&cs, backing);
        node = e.node;
        if (node & VIS_STACK_SAME_INTERVAL) {
            node &= ~VIS_STACK_SAME_INTERVAL;
            t_min = e.t_max;
        } else {
            t_min = t_max;
            t_max = e.t_max;
        }
        if (t_min > vis_t_limit(h->t)) {
            /* As in vis_traverse_stack: an in-plane far side below may still be due. */
            for (;;) {
                uint32_t sp = cs.nb + cs.nc;
                int k = (int)sp - 1;
                while (k >= 0 && !(vis_cached_entry(&cs, backing, (uint32_t)k).node & VIS_STACK_SAME_INTERVAL))
                    --k;
                if (k < 0)
                    return;
                if ((uint32_t)k + 1u < sp)
                    t_max = vis_cached_entry(&cs, backing, (uint32_t)k + 1u).t_max;
                e = vis_cached_entry(&cs, backing, (uint32_t)k);
                vis_cached_truncate(&cs, (uint32_t)k);
                node = e.node & ~VIS_STACK_SAME_INTERVAL;
                t_min = e.t_max;
                if (!(t_min > vis_t_limit(h->t)))
                    break;
            }
        }
    }
}

/* ---- the cell-grid walk (3D-DDA) -----------------------------------------------------------
 *
 * At full depth every leaf of the fixed-depth tree is one cell of the scene's cell grid and
 * every inner cell boundary is a split plane, so the leaves a ray visits, in order, are the
 * cells it crosses: a 3D-DDA over the grid (Amanatides & Woo 1987; uniform sub-volumes, Lee &
 * Han 2005, seeds/001) finds them with no tree and no stack, and a map fixed at build
 * (vis_ray_setup.cell_map) gives each cell's leaf. The leaf itself is vis_leaf_intersect's.
 *
 * Exactness (docs/traversal.md, "Exactness"). A quad is taken, by every method, when its box
 * passes the slab test within vis_t_limit's slack; its box lies in its cell, and distances
 * are monotone in the plane coordinate, so the cell passes the same test: max(t0, entry
 * distances) <= lim(min(t1, exit distances)), every distance (c - o[a]) * inv[a] with c =
 * (float)i * cell_size, the split planes' own floats. The walk must visit every cell that
 * passes (a superset only adds real hits). Call a crossing the distance at which the ray
 * meets an inner boundary. Between crossings the walk is the plain DDA; where crossings of
 * two or three axes follow each other within the slack (a chain: each within lim of the one
 * before; the ray passes an edge or a corner), a cell whose entry on one axis comes after its
 * exit on another can still pass. Such a cluster of crossings, on the axes A, leads from cell
 * P to P + e(A), and the cells that can pass around it are P + e(S) for the subsets S of A
 * (an axis outside A keeps its index across the cluster; one in A has crossed once): the walk
 * visits all 2^|A| of them (the kd walk's "both" cases, here as a block). That holds while no
 * axis crosses twice within one chain, i.e. while a cell is far wider than the slack at that
 * distance (16 voxels against 2^-20 t: t under about 5 million voxels); a ray for which
 * that fails is finished by the brute force (exact, slow, never met in our scenes).
 * Termination is the stack method's: a cell is skipped once its entry lies beyond
 * lim(best hit), and entries only grow along the walk.
 *
 * A ray lying in an inner boundary plane (d[a] = 0, o[a] on it) is walked once with each
 * of the two cells it touches on that axis, as the kd walk visits both children. A leaf
 * spanning several cells (a tree built shallower than full depth) would be visited once per
 * cell; the host maps the method to the stack method for such scenes (cell_map = 0). */

/* The distance to inner boundary b (1..n-1) of axis a: the split distance expression. */
VIS_INLINE float vis_dda_cross(const vis_ray *r, uint32_t a, int b, float cs)
{
    return ((float)b * cs - r->o[a]) * r->inv[a];
}

/* The distance at which the ray leaves cell i of axis a moving by step (VIS_INF past the
 * last inner boundary: the scene clip ends the ray there). */
VIS_INLINE float vis_dda_exit(const vis_ray *r, uint32_t a, int i, int step, int n, float cs)
{
    int b = step > 0 ? i + 1 : i;
    return b >= 1 && b <= n - 1 ? vis_dda_cross(r, a, b, cs) : VIS_INF;
}

/* vis_dda_exit by the boundary itself: b's distance, or VIS_INF at b = end (n moving up, 0
 * moving down: past the last inner boundary). */
VIS_INLINE float vis_dda_bound(const vis_ray *r, uint32_t a, int b, int end, float cs)
{
    return b != end ? vis_dda_cross(r, a, b, cs) : VIS_INF;
}

#if !defined(VIS_DDA_ONE_WALK)
#  if defined(__OPENCL_VERSION__)
#    define VIS_DDA_ONE_WALK 0
#  else
#    define VIS_DDA_ONE_WALK 1
#  endif
#endif

/* A test may define VIS_DDA_VISIT(entry) before including this file to see each cell visited
 * (its map entry, cell_map + cell; tests/test_traversal.c holds the walk to the cell test
 * above). */
#ifndef VIS_DDA_VISIT
#  define VIS_DDA_VISIT(entry) ((void)0)
#endif

/* The leaf of map entry `entry` over [ta, tb]: a cell with a clearance costs only its map
 * entry, an empty leaf without one its header too. Returns whether the leaf was tested (only
 * then can the best hit have changed); *clear gets the cell's clearance. */
VIS_INLINE int vis_dda_leaf(const vis_ray *r, uint32_t entry, float ta, float tb, uint32_t *clear, VIS_SCENE_PARAMS,
                            vis_hit *h)
{
    VIS_DDA_VISIT(entry);
    uint32_t e = rope_index[entry];
    *clear = VIS_CELL_CLEAR(e);
    if (*clear)
        return 0;
    const VIS_GLOBAL vis_flat_leaf *leaf = &leaves[VIS_CELL_LEAF(e)];
    if (!vis_leaf_has_primitives(leaf))
        return 0;
    vis_leaf_intersect(r, leaf, buckets, quads, tris, objects VIS_LEAF_LABELS(VIS_CELL_LEAF(e)), ta, tb, h);
    return 1;
}

/* One walk from cell m0 (the lowest cell, in the ray's direction, that can pass at t0).
 * Returns 0 when a chain crossed an axis twice (the caller finishes the ray otherwise). The
 * state is in scalars, axis by axis, so that it stays in registers. */
VIS_INLINE int vis_dda_walk(const vis_ray *r, const vis_ray_setup *s, const int *m0, const int *step, float t0,
                            float t1, VIS_SCENE_PARAMS, vis_hit *h)
{
    float cs = s->cell_size;
    int nx = (int)s->cells[0], ny = (int)s->cells[1], nz = (int)s->cells[2];
    int sx = step[0], sy = step[1], sz = step[2];
    /* The next boundary each axis crosses (vis_dda_exit's b) and the one past its last inner
     * boundary, where the crossing is VIS_INF: one compare per step instead of the range. */
    int bx = m0[0] + (sx > 0), by = m0[1] + (sy > 0), bz = m0[2] + (sz > 0);
    int ex = sx > 0 ? nx : 0, ey = sy > 0 ? ny : 0, ez = sz > 0 ? nz : 0;
    /* The cell's map entry, and what a step on each axis adds to it. */
    uint32_t entry = s->cell_map + (uint32_t)m0[0] + s->cells[0] * ((uint32_t)m0[1] + s->cells[1] * (uint32_t)m0[2]);
    uint32_t dx = (uint32_t)sx, dy = (uint32_t)sy * s->cells[0], dz = (uint32_t)sz * s->cells[0] * s->cells[1];
    float tx = sx ? vis_dda_bound(r, 0u, bx, ex, cs) : VIS_INF;
    float ty = sy ? vis_dda_bound(r, 1u, by, ey, cs) : VIS_INF;
    float tz = sz ? vis_dda_bound(r, 2u, bz, ez, cs) : VIS_INF;
    float T = t0; /* where the current cell is entered */
    /* The walk stops at a cell entered beyond lim(best hit) or lim(t1): one bound, renewed
     * only where the best hit can change (after a leaf that holds primitives). */
    float lim_t1 = vis_t_limit(t1);
    float stop = vis_t_limit(h->t) < lim_t1 ? vis_t_limit(h->t) : lim_t1;
    /* Steps known to lead only to empty cells. A step moves the walk by at most one cell on
     * each axis, and the cells around an edge or corner that it visits are within one cell of
     * the cell it left, so the k-th step from a cell of clearance c (its map entry) stays
     * within Chebyshev distance k of it: the next c - 1 steps meet only empty leaves, whose
     * map entries and headers are not read (empty-space skipping; Lee & Han 2005, seeds/001,
     * and the distance fields of voxel ray casters). The cells are still stepped through one
     * by one, so the walk's geometry, and every cell it would test, is unchanged. */
    uint32_t free_steps = 0u;
    for (;;) {
        if (T > stop)
            return 1;
        float e = tx < ty ? tx : ty;
        e = tz < e ? tz : e;
        if (!(e <= VIS_INF))
            return 0; /* a NaN crossing (a ray made elsewhere with an infinite reciprocal) */
        if (free_steps) {
            VIS_DDA_VISIT(entry);
            --free_steps;
        } else {
            uint32_t clear;
            if (vis_dda_leaf(r, entry, T, e < t1 ? e : t1, &clear, VIS_SCENE_ARGS, h))
                stop = vis_t_limit(h->t) < lim_t1 ? vis_t_limit(h->t) : lim_t1;
            free_steps = clear ? clear - 1u : 0u;
        }
        if (e == VIS_INF)
            return 1;
        float lim = vis_t_limit(e);
        uint32_t set = (tx <= lim ? 1u : 0u) | (ty <= lim ? 2u : 0u) | (tz <= lim ? 4u : 0u);
        if (set == 0u)
            return 0; /* no axis steps: never loop in place */
        float last = e;
        if (set & (set - 1u)) {
            /* The cluster: the crossings chained to e within the slack (a second round
             * catches the third axis chained to the second), then the block around the edge
             * or corner: every P + e(S), S a proper non-empty subset of the cluster's axes
             * (P + e(A) is the next cell of the walk). */
            last = (set & 1u) && tx > last ? tx : last;
            last = (set & 2u) && ty > last ? ty : last;
            last = (set & 4u) && tz > last ? tz : last;
            lim = vis_t_limit(last);
            set |= (tx <= lim ? 1u : 0u) | (ty <= lim ? 2u : 0u) | (tz <= lim ? 4u : 0u);
            last = (set & 1u) && tx > last ? tx : last;
            last = (set & 2u) && ty > last ? ty : last;
            last = (set & 4u) && tz > last ? tz : last;
            if (e <= stop) {
                for (uint32_t sub = 1u; sub < set; ++sub)
                    if ((sub & set) == sub) {
                        uint32_t at = entry + ((sub & 1u) ? dx : 0u) + ((sub & 2u) ? dy : 0u) + ((sub & 4u) ? dz : 0u);
                        uint32_t clear;
                        if (free_steps)
                            VIS_DDA_VISIT(at); /* within the steps known empty, as the next cell */
                        else
                            vis_dda_leaf(r, at, e, last, &clear, VIS_SCENE_ARGS, h);
                    }
                stop = vis_t_limit(h->t) < lim_t1 ? vis_t_limit(h->t) : lim_t1;
            }
            lim = vis_t_limit(last); /* without a cluster, last is e and lim already this */
        }
        if (set & 1u) {
            bx += sx;
            entry += dx;
            tx = vis_dda_bound(r, 0u, bx, ex, cs);
            if (tx <= lim)
                return 0; /* an axis crosses twice within the chain */
        }
        if (set & 2u) {
            by += sy;
            entry += dy;
            ty = vis_dda_bound(r, 1u, by, ey, cs);
            if (ty <= lim)
                return 0;
        }
        if (set & 4u) {
            bz += sz;
            entry += dz;
            tz = vis_dda_bound(r, 2u, bz, ez, cs);
            if (tz <= lim)
                return 0;
        }
        T = last;
    }
}

VIS_INLINE void vis_traverse_dda(const vis_ray *r, const vis_ray_setup *s, VIS_SCENE_PARAMS, vis_hit *h)
{
    if (s->cell_map == 0u) {
        vis_traverse_bruteforce(r, s, VIS_SCENE_ARGS, h); /* no map (the host never asks for it then) */
        return;
    }
    float t0, t1;
    if (!vis_clip_scene(r, s->size, &t0, &t1))
        return;
    float cs = s->cell_size;
    int m0[3], step[3], alt[3];
    for (uint32_t a = 0u; a < 3u; ++a) {
        int n = (int)s->cells[a];
        float o = r->o[a], d = r->d[a];
        alt[a] = 0;
        if (d == 0.0f) {
            /* The cell holding o (clip_scene has it in [0, size]); on an inner boundary, both. */
            step[a] = 0;
            int g = vis_clamp_plane(o / cs, 0, n - 1);
            while (g > 0 && o < (float)g * cs)
                --g;
            while (g < n - 1 && o >= (float)(g + 1) * cs)
                ++g;
            m0[a] = g;
            alt[a] = g > 0 && o == (float)g * cs;
            continue;
        }
        /* The first cell the ray can be in at t0 within the slack: the lowest (d > 0) or
         * highest (d < 0) index whose exit distance e has t0 <= lim(e). A guess from the
         * entry point, then corrected by the exit distances themselves. */
        step[a] = d > 0.0f ? 1 : -1;
        int g = vis_clamp_plane((o + t0 * d) / cs, 0, n - 1);
        for (;;) {
            int back = g - step[a];
            if (back >= 0 && back <= n - 1 && t0 <= vis_t_limit(vis_dda_exit(r, a, back, step[a], n, cs)))
                g = back;
            else
                break;
        }
        while (t0 > vis_t_limit(vis_dda_exit(r, a, g, step[a], n, cs)))
            g += step[a]; /* the last cell's exit is VIS_INF: ends in range */
        m0[a] = g;
    }
    /* Once per combination of the in-plane axes' two cells; almost every ray lies in no
     * boundary plane and takes one walk. On the CPU that walk is taken directly; an OpenCL
     * kernel keeps the loop's one call site: with the direct call (a second inlined copy of
     * the walk) the H200's dda kernel ran about 3x slower, without it as before (docs/opencl.md,
     * "The session's merged tree on the H200, and a dda regression caught"). */
#if VIS_DDA_ONE_WALK
    if (!(alt[0] | alt[1] | alt[2])) {
        if (!vis_dda_walk(r, s, m0, step, t0, t1, VIS_SCENE_ARGS, h))
            vis_traverse_bruteforce(r, s, VIS_SCENE_ARGS, h);
        return;
    }
#endif
    for (uint32_t v = 0u; v < 8u; ++v) {
        if (((v & 1u) && !alt[0]) || ((v & 2u) && !alt[1]) || ((v & 4u) && !alt[2]))
            continue;
        int m[3];
        for (uint32_t a = 0u; a < 3u; ++a)
            m[a] = m0[a] - (int)(v >> a & 1u);
        if (!vis_dda_walk(r, s, m, step, t0, t1, VIS_SCENE_ARGS, h)) {
            vis_traverse_bruteforce(r, s, VIS_SCENE_ARGS, h);
            return;
        }
    }
}

/* The ray through the method with VIS_TRAVERSAL_ID `method`. Packets are the CPU's own, and
 * the cached stack needs its caller's ring: a ray handed here with either goes through the
 * stack method, whose walk (and so whose buffers) the cached stack repeats exactly. */
VIS_INLINE void vis_traverse(const vis_ray *r, const vis_ray_setup *s, uint32_t method, VIS_SCENE_PARAMS, vis_hit *h)
{
    if (method == VIS_TRAVERSAL_ID_STACK || method == VIS_TRAVERSAL_ID_PACKET ||
        method == VIS_TRAVERSAL_ID_CACHED_STACK)
        vis_traverse_stack(r, s, VIS_SCENE_ARGS, h);
    else if (method == VIS_TRAVERSAL_ID_BRUTEFORCE)
        vis_traverse_bruteforce(r, s, VIS_SCENE_ARGS, h);
    else if (method == VIS_TRAVERSAL_ID_DDA)
        vis_traverse_dda(r, s, VIS_SCENE_ARGS, h);
    else if (method == VIS_TRAVERSAL_ID_ROPES || method == VIS_TRAVERSAL_ID_ROPES_SHORTSTACK)
        vis_traverse_ropes(r, s, method == VIS_TRAVERSAL_ID_ROPES ? 0u : s->short_stack, VIS_SCENE_ARGS, h);
    else
        vis_traverse_restart(r, s, method == VIS_TRAVERSAL_ID_SHORTSTACK ? s->short_stack : 0u,
                             method == VIS_TRAVERSAL_ID_PUSHDOWN, VIS_SCENE_ARGS, h);
}

/* One pixel: the ray, the traversal chosen by s->traversal, the ID and depth to write, and
 * the hit's object slot (VIS_NO_OBJECT: none) for the draw list built on a device. ring: the
 * cached stack's ring, slot j at ring[j * ring_stride], j < s->short_stack (only
 * VIS_TRAVERSAL_ID_CACHED_STACK uses it).
 * A kernel built for one method only may define VIS_TRAVERSAL_ONLY to its VIS_TRAVERSAL_ID_*
 * (e.g. -DVIS_TRAVERSAL_ONLY=5u): the switch is then a constant and the other methods, with
 * their private stacks, compile away (s->traversal is ignored). */
VIS_INLINE void vis_trace_pixel_slot(const vis_ray_setup *s, uint32_t x, uint32_t y, VIS_SCENE_PARAMS,
                                     VIS_RING_SPACE vis_stack_entry *ring, uint32_t ring_stride, uint32_t *out_id,
                                     float *out_depth, uint32_t *out_slot)
{
    vis_ray r;
    vis_ray_for_pixel(s, x, y, &r);
    vis_hit h;
#ifdef VIS_TRACE_EFFECTS
    vis_hit_init(&h, VIS_ST_OCCLUDE, 0u, VIS_NO_AXIS, 0.0f); /* the plain pass, in an effects program */
#else
    h.t = VIS_INF;
    h.object = VIS_NO_OBJECT;
    h.id = 0u;
#endif
#ifdef VIS_TRAVERSAL_ONLY
    uint32_t method = VIS_TRAVERSAL_ONLY;
#else
    uint32_t method = s->traversal;
#endif
    if (method == VIS_TRAVERSAL_ID_CACHED_STACK)
        vis_traverse_cached_stack(&r, s, ring, ring_stride, s->short_stack, VIS_SCENE_ARGS, &h);
    else
        vis_traverse(&r, s, method, VIS_SCENE_ARGS, &h);
    *out_slot = h.object;
    if (h.object == VIS_NO_OBJECT) {
        *out_id = 0u;
        *out_depth = VIS_INF;
        return;
    }
    *out_id = s->id_mode == 1u ? vis_hit_leaf_id(&r, &h, VIS_SCENE_ARGS) : h.id;
    *out_depth = h.t;
}

#ifndef __OPENCL_VERSION__
/* vis_trace_pixel_slot without the slot, the cached stack's ring on the C stack. (A device
 * kernel calls vis_trace_pixel_slot with its work-item's slice of local memory.) */
VIS_INLINE void vis_trace_pixel(const vis_ray_setup *s, uint32_t x, uint32_t y, VIS_SCENE_PARAMS, uint32_t *out_id,
                                float *out_depth)
{
    vis_stack_entry ring[VIS_MAX_SHORT_STACK];
    uint32_t slot;
    vis_trace_pixel_slot(s, x, y, VIS_SCENE_ARGS, ring, 1u, out_id, out_depth, &slot);
}
#endif

#ifdef VIS_TRACE_EFFECTS
/* ---- effects (docs/effects.md) -----------------------------------------------------------
 *
 * One pixel with the pass's effects: the primary ray with its see-through policy, then at
 * most two secondary rays, each traced alone (they are incoherent) by the stack method, or by
 * the brute force when that is the pass's method (the reference stays tree-free):
 *  - see-through: a see-through primitive never becomes the hit, so every method walks to the
 *    opaque hit and offers every see-through crossing nearer than it (the exactness argument
 *    of docs/traversal.md, unchanged); the list is then cut to the crossings that beat the
 *    opaque hit in vis_hit_better's (t, ID) order -- the same set in every method;
 *  - reflect: one reflected ray from the nearest reflective surface met (the nearest
 *    reflective see-through crossing that beats the opaque hit, else the opaque hit if it is
 *    a reflective quad): exact for an axis-aligned quad, d[axis] negated, the origin on the
 *    quad's plane exactly, quads of that plane ignored; triangles do not reflect;
 *  - shadows (Bittner, Mattausch, Silvennoinen, Wimmer 2011, "Shadow Caster Culling for
 *    Efficient Shadow Mapping"): from the opaque hit, when it is a quad whose seen side faces
 *    the light, a ray toward the light from the hit point (plane coordinate exact, that plane
 *    ignored) to the scene bounds; its first hit is the shadow caster. See-through quads are
 *    not there for it (they cast no shadow); a seen side facing away from the light is its
 *    own shadow (no ray, 0); triangle receivers cast no ray. */

typedef struct vis_effect_pixel {
    uint32_t id;
    float depth;
    uint32_t reflection;              /* VIS_FX_REFLECT: ID the reflected ray hits, 0: none */
    uint32_t shadow;                  /* VIS_FX_SHADOWS: the caster's ID, 0: none            */
    uint32_t secondary;               /* secondary rays cast (0..2)                          */
    uint32_t see_through[VIS_MAX_LAYERS]; /* nearest first, 0 past the last                  */
} vis_effect_pixel;

/* A secondary ray from o along d over [0, t_far], ignoring the quads of plane `plane` on
 * `axis`; returns the ID of its first hit (0: none). */
VIS_INLINE uint32_t vis_trace_secondary(const vis_ray_setup *s, uint32_t method, const float *o, const float *d,
                                        float t_far, uint32_t policy, uint32_t axis, float plane, VIS_SCENE_PARAMS)
{
    vis_ray r;
    for (int a = 0; a < 3; ++a) {
        r.o[a] = o[a];
        r.d[a] = vis_dir_component(d[a]);
        r.inv[a] = 1.0f / r.d[a];
    }
    r.t_near = 0.0f;
    r.t_far = t_far;
    vis_hit h;
    vis_hit_init(&h, policy, 0u, axis, plane);
    if (method == VIS_TRAVERSAL_ID_BRUTEFORCE)
        vis_traverse_bruteforce(&r, s, VIS_SCENE_ARGS, &h);
    else
        vis_traverse_stack(&r, s, VIS_SCENE_ARGS, &h);
    return h.object == VIS_NO_OBJECT ? 0u : h.id;
}

/* What a pixel gets from its primary ray's ray r and final hit state h (traced by `method`
 * with fx's see-through policy): the ID, depth and see-through layers, then its secondary
 * rays. The per-ray pass (vis_trace_pixel_effects) and the CPU's packets (packet_impl.h) end
 * each pixel here. */
VIS_INLINE void vis_effects_finish(const vis_ray_setup *s, const vis_effect_setup *e, uint32_t fx, uint32_t method,
                                   const vis_ray *r, const vis_hit *h, VIS_SCENE_PARAMS, vis_effect_pixel *out)
{
    uint32_t st = fx & VIS_FX_SEE_THROUGH;
    int hit = h->object != VIS_NO_OBJECT;
    out->id = hit ? h->id : 0u;
    out->depth = hit ? h->t : VIS_INF;
    /* Sorted by (t, ID): the crossings that beat the opaque hit are a prefix. */
    for (uint32_t k = 0u; k < VIS_MAX_LAYERS; ++k)
        out->see_through[k] = k < h->st_n && vis_hit_better(h->st_t[k], h->st_id[k], h) ? h->st_id[k] : 0u;
    out->reflection = 0u;
    out->shadow = 0u;
    out->secondary = 0u;
    uint32_t second = method == VIS_TRAVERSAL_ID_BRUTEFORCE ? method : VIS_TRAVERSAL_ID_STACK;
    if (fx & VIS_FX_REFLECT) {
        float t = 0.0f, plane = 0.0f;
        uint32_t prim = 3u;
        if (h->rid != 0u && vis_hit_better(h->rt, h->rid, h)) {
            t = h->rt;
            prim = h->rprim;
            plane = h->rplane;
        } else if (hit && (h->prim & 3u) != 3u && (h->prim >> 2 & VIS_FLAG_REFLECTIVE)) {
            t = h->t;
            prim = h->prim;
            plane = h->plane;
        }
        uint32_t a = prim & 3u;
        if (a != 3u) {
            float o[3], d[3];
            for (uint32_t i = 0u; i < 3u; ++i) {
                o[i] = r->o[i] + t * r->d[i];
                d[i] = r->d[i];
            }
            o[a] = plane;
            d[a] = -d[a];
            ++out->secondary;
            out->reflection = vis_trace_secondary(s, second, o, d, s->t_far, st ? VIS_ST_SKIP : VIS_ST_OCCLUDE, a,
                                                  plane, VIS_SCENE_ARGS);
        }
    }
    if ((fx & VIS_FX_SHADOWS) && hit && (h->prim & 3u) != 3u) {
        uint32_t a = h->prim & 3u;
        /* The seen side faces -d[a] (d[a] != 0 for a quad hit); lit when the light is on it. */
        float facing = r->d[a] > 0.0f ? -e->light[a] : e->light[a];
        if (facing > 0.0f) {
            float o[3];
            for (uint32_t i = 0u; i < 3u; ++i)
                o[i] = r->o[i] + h->t * r->d[i];
            o[a] = h->plane;
            ++out->secondary;
            out->shadow =
                vis_trace_secondary(s, second, o, e->light, VIS_INF, VIS_ST_SKIP, a, h->plane, VIS_SCENE_ARGS);
        }
    }
}

VIS_INLINE void vis_trace_pixel_effects(const vis_ray_setup *s, const vis_effect_setup *e, uint32_t x, uint32_t y,
                                        VIS_SCENE_PARAMS, vis_effect_pixel *out)
{
    vis_ray r;
    vis_ray_for_pixel(s, x, y, &r);
    /* A program built for one effect set defines VIS_EFFECTS_ONLY to its bits: the code of
     * the other effects compiles away. */
#ifdef VIS_EFFECTS_ONLY
    uint32_t fx = VIS_EFFECTS_ONLY;
#else
    uint32_t fx = e->effects;
#endif
    vis_hit h;
    vis_hit_init(&h, (fx & VIS_FX_SEE_THROUGH) ? VIS_ST_RECORD : VIS_ST_OCCLUDE, e->layers, VIS_NO_AXIS, 0.0f);
#ifdef VIS_TRAVERSAL_ONLY
    uint32_t method = VIS_TRAVERSAL_ONLY;
#else
    uint32_t method = s->traversal;
#endif
    vis_traverse(&r, s, method, VIS_SCENE_ARGS, &h);
    vis_effects_finish(s, e, fx, method, &r, &h, VIS_SCENE_ARGS, out);
}
#endif /* VIS_TRACE_EFFECTS */

#endif /* VIS_TRACE_CORE_H */
