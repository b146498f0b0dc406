/* packet.c — which packet size traces a tile (packet_impl.h has the tracing).
 *
 * A packet's bounds are only as tight as its rays are close: a 16x16 tile at 512x512 and a
 * 60 degree field of view spans about 2 degrees, and its culls remove almost everything; the
 * same tile of a 32x32 image spans 30 degrees and culls almost nothing, so every leaf in view
 * is opened for it. So a pass takes the largest packets (16x16 or 8x8) whose tiles spread no
 * wider than PACKET_MAX_SPREAD, else 4x4 packets up to PACKET_MAX_SPREAD_4; wider than that,
 * each ray goes alone.
 *
 * Far away a small packet over-reaches in the same way: where a pixel covers more than
 * PACKET_MAX_FOOTPRINT scene units, an 8x8 or 4x4 tile spans several leaves, its bounds stop
 * culling, and every quad in its rectangle is tested against its rays (docs/performance.md:
 * on gen:city's overview such packets cost 4-7x their single rays). The packet walk goes near
 * side first, so the first leaf it enters tells: entered beyond that distance, the packet
 * gives up and its rays go one by one. 16x16 packets (normal image sizes) give up the same way
 * past PACKET_FAR_FOOTPRINT: their work per ray grows with the square of the footprint (the
 * leaves a tile opens grow with its area, its rays stay 256), a lone ray's hardly at all, and
 * on gen:large's far views (about 5 voxels per pixel) the lone rays are the cheaper. Every
 * path gives the same pixels: the brute force's.
 *
 * Where the eye is farther than that distance from everything in the scene (a small pass or
 * gen:large's far views, seen from high above), all or nearly all packets would give up, after
 * walking the tree to their first leaf: such an ID pass sends its tiles alone from the start,
 * but for tiles of sky (a corner ray misses the scene's content), whose packets end cheaply,
 * with no leaf (docs/performance.md, "Far passes skip the packets that would give up"). A
 * packet's own test is conservative (its rays' nearest entry, the box widened), so a skipped
 * packet might not have given up: that costs time, never pixels. Effects passes keep their
 * packets.
 *
 * A ray that goes alone (a pass too wide for 4x4 packets, or a packet that gave up) walks the
 * cell grid (trace_core.h, vis_traverse_dda) where the scene has its cell map: on gen:city's
 * overview at 171x96 and 64x64 the pass took 13-14 % fewer instructions than with packets of
 * one ray (docs/performance.md, "A per-ray walk over the cell grid"). vis_trace_cost's pass
 * keeps the packets of one ray, which count their work. */
#include <limits.h>
#include <math.h>

#include "cpu/packet.h"

int vis_packet_trace_16x16(const vis_ray_setup *setup, const vis_scene_view *view, const vis_node_fill *fill,
                           float give_up_t, int max_leaves, uint32_t x0, uint32_t y0, uint32_t *ids, float *depth,
                           uint32_t *cost);
int vis_packet_trace_8x8(const vis_ray_setup *setup, const vis_scene_view *view, const vis_node_fill *fill,
                         float give_up_t, int max_leaves, uint32_t x0, uint32_t y0, uint32_t *ids, float *depth,
                         uint32_t *cost);
int vis_packet_trace_4x4(const vis_ray_setup *setup, const vis_scene_view *view, const vis_node_fill *fill,
                         float give_up_t, int max_leaves, uint32_t x0, uint32_t y0, uint32_t *ids, float *depth,
                         uint32_t *cost);
int vis_packet_trace_1x1(const vis_ray_setup *setup, const vis_scene_view *view, const vis_node_fill *fill,
                         float give_up_t, int max_leaves, uint32_t x0, uint32_t y0, uint32_t *ids, float *depth,
                         uint32_t *cost);

/* Widest tile of 16x16 or 8x8 packets, as its extent on the image plane at distance 1
 * (tangent units): at 60 degrees, 512x512 tiles of 16 span 0.036 and 256x256 ones 0.072
 * (16x16 packets 2.5-3.5x faster than single rays there), 128x128 ones 0.144 (a tie);
 * docs/traversal.md. */
#ifndef PACKET_MAX_SPREAD
#  define PACKET_MAX_SPREAD 0.1f
#endif

/* The same for 4x4 packets, the last size before rays go alone. Sixteen rays close together
 * still share most of their walk where their hits lie near, and the footprint rule below
 * sends the far ones alone: 4x4 packets executed 24-70 % fewer instructions than lone rays on
 * a server's chunk passes (32x32 faces of 90 degrees: 0.25) over gen:city, gen:default and
 * gen:maze, and 9-50 % fewer on the camera paths of 24x24 and 40x40 images at 60 degrees
 * (0.19, 0.12); at 16x16 (0.29) gen:default's path took 65 % more, so the limit stops just
 * past a 90-degree face of 32 (docs/performance.md, "4x4 packets for passes of wide pixels"). */
#ifndef PACKET_MAX_SPREAD_4
#  define PACKET_MAX_SPREAD_4 0.26f
#endif

/* Scene units a pixel may cover where a tile enters its first leaf for it to stay a packet. */
#ifndef PACKET_MAX_FOOTPRINT
#  define PACKET_MAX_FOOTPRINT 3.0f
#endif

/* The same for 16x16 packets, by instruction counts (docs/performance.md, "16x16 packets give
 * up at three scene units per pixel"): 4 until lone rays got cheaper; at 3 gen:city's far
 * views at 341x192 take 12-49 % fewer instructions and a 1024-wide terrain's overview 1.8 %
 * fewer, with no view measured costing more; at 2.5 or 2 that terrain's top-down view, whose
 * packets find their hits in their first leaf, costs 5.6 % or 48 % more. */
#ifndef PACKET_FAR_FOOTPRINT
#  define PACKET_FAR_FOOTPRINT 3.0f
#endif

/* 4x4 packets whose tiles spread at least PACKET_WIDE_SPREAD_4 (a server's 32x32 faces of 90
 * degrees spread 0.25; 60 degree images 18 to 23 pixels tall too) also give up once they
 * have entered more than PACKET_WIDE_LEAVES_4 leaves: such a tile looking along the ground
 * (over hills, down a street) opens leaf after leaf with every quad in its wide rectangle,
 * and its rays alone cost less (docs/server.md, "Wide 4x4 packets give up after four
 * leaves"). Narrower 4x4 tiles keep their walk: on a terrain's 24x24 and 40x40 passes the
 * same cap cost more than it saved. Effects packets keep theirs too (not measured). */
#ifndef PACKET_WIDE_SPREAD_4
#  define PACKET_WIDE_SPREAD_4 0.2f
#endif
#ifndef PACKET_WIDE_LEAVES_4
#  define PACKET_WIDE_LEAVES_4 4
#endif

static float vec_len(const float *v) { return sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

/* A pixel's extent on the image plane at distance 1, the larger of its two sides. */
static float pixel_extent(const vis_ray_setup *setup)
{
    /* Pixels step 2/W along `right` and 2/H along `up`. */
    return fmaxf(2.0f * vec_len(setup->right) / (float)setup->width, 2.0f * vec_len(setup->up) / (float)setup->height);
}

/* The distance past which a packet of `side` entering its first leaf gives up: where a pixel
 * there covers the footprint limit. */
static inline float give_up_distance(const vis_ray_setup *setup, uint32_t side)
{
    return (side == 16u ? PACKET_FAR_FOOTPRINT : PACKET_MAX_FOOTPRINT) / pixel_extent(setup);
}

float vis_packet_give_up_t(const vis_ray_setup *setup, uint32_t side) { return give_up_distance(setup, side); }

/* The leaves a packet of `side` may enter before it gives up (INT_MAX: no limit). */
static int max_leaves(const vis_ray_setup *setup, uint32_t side)
{
    return side == 4u && 4.0f * pixel_extent(setup) >= PACKET_WIDE_SPREAD_4 ? PACKET_WIDE_LEAVES_4 : INT_MAX;
}

uint32_t vis_packet_side(const vis_ray_setup *setup)
{
    float pixel = pixel_extent(setup);
    for (uint32_t side = VIS_PACKET_SIDE; side >= 8u; side /= 2u)
        if ((float)side * pixel <= PACKET_MAX_SPREAD)
            return side;
    return 4.0f * pixel <= PACKET_MAX_SPREAD_4 ? 4u : 1u;
}

typedef int (*packet_fn)(const vis_ray_setup *, const vis_scene_view *, const vis_node_fill *, float, int, uint32_t,
                         uint32_t, uint32_t *, float *, uint32_t *);

/* The pixels [x0, x1) x [y0, y1), one ray at a time. */
static uint32_t trace_alone(const vis_ray_setup *setup, const vis_scene_view *view, const vis_node_fill *fill,
                            uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1, uint32_t *ids, float *depth,
                            uint32_t *cost)
{
    vis_ray_setup alone = *setup; /* the rays that go alone, by the cell-grid walk */
    alone.traversal = VIS_TRAVERSAL_ID_DDA;
    int grid = setup->cell_map != 0u && cost == NULL;
    for (uint32_t y = y0; y < y1; ++y)
        for (uint32_t x = x0; x < x1; ++x) {
            if (!grid) {
                vis_packet_trace_1x1(setup, view, fill, INFINITY, INT_MAX, x, y, ids, depth, cost);
                continue;
            }
            uint32_t id;
            float t;
            vis_trace_pixel(&alone, x, y, VIS_SCENE_VIEW_ARGS(view), &id, &t);
            size_t at = (size_t)y * setup->width + x;
            ids[at] = id;
            if (depth)
                depth[at] = t;
        }
    return (x1 - x0) * (y1 - y0);
}

/* The scene's content box: its box narrowed on y to the root's fill (0: nothing in it). */
static int content_box(const vis_scene_view *view, const vis_node_fill *fill, float lo[3], float hi[3])
{
    if (view->node_count == 0u || !vis_node_filled(fill[0]))
        return 0;
    lo[0] = lo[2] = 0.0f;
    hi[0] = view->size[0];
    hi[2] = view->size[2];
    lo[1] = vis_node_fill_lo(fill[0], 0.0f, view->size[1]);
    hi[1] = vis_node_fill_hi(fill[0], 0.0f, view->size[1]);
    return 1;
}

/* Whether the packets of a pass would give up at the first leaf they enter: the eye lies
 * farther than give_up_t from the content box, which holds every leaf's content box. Rays
 * are unit length to within a few ulps, hence the margin. */
static int content_beyond(const vis_ray_setup *setup, const float lo[3], const float hi[3], float give_up_t)
{
    float d2 = 0.0f;
    for (int a = 0; a < 3; ++a) {
        float o = setup->origin[a];
        float g = o < lo[a] ? lo[a] - o : o > hi[a] ? o - hi[a] : 0.0f;
        d2 += g * g;
    }
    return isfinite(give_up_t) && sqrtf(d2) * (1.0f - 1.0f / 1024.0f) > give_up_t;
}

/* Whether pixel (x, y)'s ray passes through the box [lo, hi]. */
static int ray_meets(const vis_ray_setup *setup, uint32_t x, uint32_t y, const float lo[3], const float hi[3])
{
    vis_ray r;
    vis_ray_for_pixel(setup, x, y, &r);
    float t0 = r.t_near, t1 = r.t_far;
    for (uint32_t a = 0; a < 3u; ++a)
        if (!vis_slab(&r, a, lo[a], hi[a], &t0, &t1))
            return 0;
    return t0 <= t1;
}

/* Whether all four corner rays of the tile [x0, x1) x [y0, y1) pass through the box: a tile
 * that a far packet would give up on, rather than one of sky that it would close cheaply. */
static int corners_meet(const vis_ray_setup *setup, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1,
                        const float lo[3], const float hi[3])
{
    return ray_meets(setup, x0, y0, lo, hi) && ray_meets(setup, x1 - 1u, y0, lo, hi) &&
           ray_meets(setup, x0, y1 - 1u, lo, hi) && ray_meets(setup, x1 - 1u, y1 - 1u, lo, hi);
}

static packet_fn packet_of(uint32_t side)
{
    return side == 16u ? vis_packet_trace_16x16 : side == 8u ? vis_packet_trace_8x8
         : side == 4u ? vis_packet_trace_4x4 : NULL;
}

uint32_t vis_packet_trace_tile(const vis_ray_setup *setup, const vis_scene_view *view, const vis_node_fill *fill,
                               uint32_t side, uint32_t edge, uint32_t x0, uint32_t y0, uint32_t *ids, float *depth,
                               uint32_t *cost)
{
    float give_up_t = give_up_distance(setup, side);
    packet_fn fn = packet_of(side);
    float lo[3], hi[3];
    int far = fn && content_box(view, fill, lo, hi) && content_beyond(setup, lo, hi, give_up_t);
    int leaves = max_leaves(setup, side);
    uint32_t x_end = x0 + edge < setup->width ? x0 + edge : setup->width;
    uint32_t y_end = y0 + edge < setup->height ? y0 + edge : setup->height;
    uint32_t alone = 0;
    for (uint32_t ty = y0; ty < y_end; ty += side)
        for (uint32_t tx = x0; tx < x_end; tx += side) {
            uint32_t x1 = tx + side < x_end ? tx + side : x_end, y1 = ty + side < y_end ? ty + side : y_end;
            if (fn && !(far && corners_meet(setup, tx, ty, x1, y1, lo, hi)) &&
                fn(setup, view, fill, give_up_t, leaves, tx, ty, ids, depth, cost))
                continue;
            alone += trace_alone(setup, view, fill, tx, ty, x1, y1, ids, depth, cost);
        }
    return alone;
}
