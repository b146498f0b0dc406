/* occlusion.c — is every segment from box E to box B blocked? A proof, not a sample.
 *
 * Servers today sample: SMAC traces up to 10 rays per pair (the centre and box corners at
 * 1.3x and 0.65x), CS2's S2FOW 39 points per target, CornerCulling 4 peek points x 8 box
 * corners, Luanti 9 rays per 16^3 block. A sliver of an entity seen past a corner between
 * two sampled rays is hidden by all of them. Here an entity is hidden only when this proof
 * succeeds:
 *
 *   If an axis-aligned plane x[a] = p lies strictly between E and B, every segment from E to
 *   B crosses it, inside the rectangle R swept by those crossings. If the opaque quads lying
 *   in that plane cover R (closed rectangles, their union), every segment is blocked.
 *
 * R is exact: the crossing s = (p - e_a) / (b_a - e_a) is monotone in e_a and b_a, and the
 * crossing's other coordinates e_u + s (b_u - e_u) are linear in e_u, b_u and s, so their
 * extremes lie at the 16 corner combinations (e_a, b_a, e_u, b_u), evaluated in double and
 * widened by a tolerance that covers the float rays of a pass (the truth the tests compare
 * with). The quads' coordinates are the floats the ray pass tests, whose touches count as hits
 * (trace_core.h, vis_quad_slab), so a pass ray crossing the covered plane hits a quad there.
 *
 * One plane rarely covers a whole pair, so the pair is cut into pieces (the CornerCulling
 * idea of bounding what a peek can see, made exhaustive): a segment is cast between the
 * pieces' centres; unblocked, the pair is SEEN; blocked, the planes of its first hits (up to
 * OCC_HITS along the segment) are the candidates; a piece that straddles a candidate plane is split on it, otherwise the larger
 * piece is halved along its longest axis. Every piece must be proven; a budget of rays bounds
 * the work, and an unfinished proof is UNKNOWN (reported visible by the caller).
 *
 * Solid ground. A voxel mesh has no quads inside solid matter, so a plane through a hill finds
 * nothing there to cover R with, and pairs on either side of one stay unsettled. When the
 * caller says where the world is solid (vis_query_solid_fn), the plane x[a] = p also blocks
 * when the box of unit cells [p - 1, p + 1] x [ceil(u0) - 1, floor(u1) + 1] x [ceil(v0) - 1,
 * floor(v1) + 1] is solid: R (on u, v: [u0, u1] x [v0, v1]) lies in the box's open interior,
 * and a segment from an eye outside solid matter to a point X there enters the matter before
 * X, at a face toward a cell outside it, which the callback's contract makes an opaque quad:
 * the segment is blocked there (closed quads; a float ray of a pass crosses plane p inside
 * R's widening, inside the box too). Such planes are tried where the centre segment runs
 * between two of its hits at least 2 voxels apart on its main axis (in terrain: from where
 * it enters a hill to where it leaves it), at the integer plane nearest the middle. A box
 * test is not a ray: it is counted apart (solid_tests), at most one per hit, and never of
 * more than VIS_QUERY_SOLID_MAX_CELLS cells.
 *
 * Limits, on the side of reporting: only quads in integer planes are found as candidates
 * (voxel meshes have no others), and triangles and see-through quads never occlude. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "occlusion.h"
#include "query_sort.h"

#define OCC_STACK 64      /* pending piece pairs; a deeper proof gives up (UNKNOWN)          */
#define OCC_MAX_QUADS 48  /* quads gathered in one plane test; more: the test fails          */
#define OCC_SEP 1e-4      /* a plane separates only with this gap on both sides (voxels)      */
#define OCC_HITS 12       /* hits along a piece pair's centre segment tried as candidates   */

/* Widening of R: a float ray of a pass differs from the exact segment by a few ulps of its
 * coordinates (trace_core.h: within 2^-20 relative of t), so R grows by that, generously. */
static double occ_tolerance(double coord_max)
{
    return 1e-5 + 4e-7 * coord_max;
}

/* One segment through the tree: 1 when no primitive is hit. */
static int segment_raw(const vis_scene_view *view, const double a[3], const double b[3], double hit_point[3])
{
    double d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(len > 0.0))
        return 1;
    vis_ray r;
    for (int i = 0; i < 3; ++i) {
        r.o[i] = (float)a[i];
        r.d[i] = vis_dir_component((float)(d[i] / len));
        r.inv[i] = 1.0f / r.d[i];
    }
    r.t_near = 0.0f;
    r.t_far = (float)len;
    vis_ray_setup s;
    memset(&s, 0, sizeof s);
    memcpy(s.size, view->size, sizeof s.size);
    s.root = 0;
    s.leaf_count = view->leaf_count;
    memcpy(s.cells, view->cells, sizeof s.cells);
    s.cell_map = view->cell_map;
    s.cell_size = view->cell_size;
    vis_hit h;
    h.t = VIS_INF;
    h.object = VIS_NO_OBJECT;
    h.id = 0;
    /* The cell-grid walk where the tree has a leaf per cell: it steps from leaf to leaf
     * without going back up the tree, which on the long segments of a proof over hills
     * took 7 % off gen:default's median tick (docs/server.md, "Proof segments on the cell
     * grid"); every method finds the same nearest hit. */
    if (view->cell_map)
        vis_traverse_dda(&r, &s, VIS_SCENE_VIEW_ARGS(view), &h);
    else
        vis_traverse_stack(&r, &s, VIS_SCENE_VIEW_ARGS(view), &h);
    if (h.object == VIS_NO_OBJECT || !(h.t <= r.t_far))
        return 1;
    if (hit_point)
        for (int i = 0; i < 3; ++i)
            hit_point[i] = (double)r.o[i] + (double)h.t * (double)r.d[i];
    return 0;
}

/* ---- plane coverage --------------------------------------------------------------------- */

typedef struct occ_rect {
    double u0, v0, u1, v1;
} occ_rect;

typedef struct occ_gather {
    uint32_t axis;
    float plane;
    occ_rect want;                   /* R                                                    */
    occ_rect quads[OCC_MAX_QUADS];
    uint32_t count;
    int overflow;
} occ_gather;

static void gather_quad(occ_gather *g, const vis_flat_quad *q)
{
    if (VIS_META_FLAGS(q->meta) & VIS_PRIM_SEE_THROUGH)
        return;
    if (q->u1 < g->want.u0 || q->u0 > g->want.u1 || q->v1 < g->want.v0 || q->v0 > g->want.v1)
        return;
    if (g->count == OCC_MAX_QUADS) {
        g->overflow = 1;
        return;
    }
    occ_rect *r = &g->quads[g->count++];
    r->u0 = q->u0;
    r->v0 = q->v0;
    r->u1 = q->u1;
    r->v1 = q->v1;
}

static void gather_leaf(occ_gather *g, const vis_scene_view *view, const vis_flat_leaf *leaf)
{
    uint32_t a = g->axis;
    const vis_flat_quad *loose = vis_loose_quads(view->quads, leaf);
    for (uint32_t i = 0; i < leaf->loose_count; ++i) {
        const vis_flat_quad *q = &loose[i];
        if (VIS_META_AXIS(q->meta) == a && q->plane == g->plane)
            gather_quad(g, q);
    }
    if (leaf->quad_count == 0)
        return;
    uint32_t E[3] = {leaf->dims_xy & 0xFFFFu, leaf->dims_xy >> 16, leaf->dims_z};
    float kf = g->plane - leaf->lo[a];
    if (!(kf >= 0.0f) || kf > (float)E[a] || kf != floorf(kf))
        return;
    uint32_t base = a == 0 ? 0u : a == 1 ? E[0] + 1u : E[0] + E[1] + 2u;
    const uint32_t *bk = view->buckets + leaf->bucket_offset;
    uint32_t b = base + (uint32_t)kf;
    /* Packed quads (trace_core.h, vis_flat_leaf): the bucket gives axis and plane. */
    for (uint32_t i = bk[b]; i < bk[b + 1]; ++i) {
        vis_flat_quad q = vis_unpack_quad(view->quads[leaf->quad_offset + i], a, (int)kf, leaf, view->quads);
        if (q.plane == g->plane)
            gather_quad(g, &q);
    }
}

/* The leaves whose closed box meets the query box, by a walk of the tree. */
static void gather(occ_gather *g, const vis_scene_view *view, const double qlo[3], const double qhi[3])
{
    uint32_t stack[96];
    int sp = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        uint32_t node = stack[--sp];
        uint32_t info = view->nodes[node].info;
        if ((info & 3u) == VIS_NODE_LEAF) {
            gather_leaf(g, view, &view->leaves[info >> 2]);
            if (g->overflow)
                return;
            continue;
        }
        uint32_t axis = info & 3u, first = info >> 2;
        double split = view->nodes[node].split;
        if (sp + 2 > (int)(sizeof stack / sizeof stack[0])) {
            g->overflow = 1; /* deeper than any tree libvis builds; fail safe */
            return;
        }
        if (qlo[axis] <= split)
            stack[sp++] = first;
        if (qhi[axis] >= split)
            stack[sp++] = first + 1u;
    }
}

/* The opaque quads of plane x[a] = p that meet `want` (on the plane's u and v axes), into g. */
static void gather_plane(occ_gather *g, const vis_scene_view *view, uint32_t a, double p, occ_rect want)
{
    uint32_t u = a == 2 ? 0u : a + 1u, v = a == 0 ? 2u : a - 1u;
    g->axis = a;
    g->plane = (float)p;
    g->want = want;
    g->count = 0;
    g->overflow = 0;
    double qlo[3], qhi[3];
    qlo[a] = qhi[a] = p;
    qlo[u] = want.u0;
    qhi[u] = want.u1;
    qlo[v] = want.v0;
    qhi[v] = want.v1;
    gather(g, view, qlo, qhi);
}

/* 1 when an opaque quad of an integer plane through x (within 1e-3) touches x. */
static int opaque_at(const vis_scene_view *view, const double x[3])
{
    for (uint32_t a = 0; a < 3; ++a) {
        double p = floor(x[a] + 0.5);
        if (!(fabs(x[a] - p) <= 1e-3))
            continue;
        occ_gather g;
        uint32_t u = a == 2 ? 0u : a + 1u, v = a == 0 ? 2u : a - 1u;
        occ_rect want = {x[u] - 1e-3, x[v] - 1e-3, x[u] + 1e-3, x[v] + 1e-3};
        gather_plane(&g, view, a, p, want);
        if (g.count || g.overflow)
            return 1;
    }
    return 0;
}

#define OCC_SEE_THROUGH_LAYERS 8

/* See-through quads (glass, water, leaves) do not block: a segment that hits one goes on
 * past it, up to OCC_SEE_THROUGH_LAYERS times (then it counts as blocked, which only ever
 * keeps an entity reported). A hit that no integer-plane quad explains (a triangle, a
 * loose quad) blocks. */
int vis_occ_segment_clear(const vis_scene_view *view, const double a[3], const double b[3], double hit_point[3])
{
    double cur[3] = {a[0], a[1], a[2]}, x[3];
    for (int layer = 0; layer <= OCC_SEE_THROUGH_LAYERS; ++layer) {
        if (segment_raw(view, cur, b, x))
            return 1;
        if (opaque_at(view, x) || layer == OCC_SEE_THROUGH_LAYERS) {
            if (hit_point)
                memcpy(hit_point, x, sizeof x);
            return 0;
        }
        /* Was it a see-through quad? Only those in integer planes are recognised. */
        int glass = 0;
        for (int k = 0; k < 3; ++k)
            glass |= fabs(x[k] - floor(x[k] + 0.5)) <= 1e-3;
        if (!glass) {
            if (hit_point)
                memcpy(hit_point, x, sizeof x);
            return 0;
        }
        double d[3] = {b[0] - cur[0], b[1] - cur[1], b[2] - cur[2]};
        double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (!(len > 2e-3))
            return 1;
        for (int k = 0; k < 3; ++k)
            cur[k] = x[k] + d[k] / len * 2e-3;
    }
    return 0;
}

static uint32_t cut_points(double lo, double hi, const occ_rect *q, uint32_t n, int use_v, double *out)
{
    uint32_t m = 0;
    out[m++] = lo;
    out[m++] = hi;
    for (uint32_t i = 0; i < n; ++i) {
        double c0 = use_v ? q[i].v0 : q[i].u0, c1 = use_v ? q[i].v1 : q[i].u1;
        if (c0 > lo && c0 < hi)
            out[m++] = c0;
        if (c1 > lo && c1 < hi)
            out[m++] = c1;
    }
    vis_sort_f64(out, m);
    return m;
}

/* Is the closed rectangle want inside the union of the closed quads? The quads' edges cut
 * want into cells; each open cell lies inside or outside every quad, so testing its middle
 * decides it, and closed quads covering every cell cover the cells' closures. */
static int covered(const occ_gather *g)
{
    double us[2 * OCC_MAX_QUADS + 2], vs[2 * OCC_MAX_QUADS + 2];
    uint32_t nu = cut_points(g->want.u0, g->want.u1, g->quads, g->count, 0, us);
    uint32_t nv = cut_points(g->want.v0, g->want.v1, g->quads, g->count, 1, vs);
    for (uint32_t i = 0; i + 1 < nu; ++i) {
        double mu = 0.5 * (us[i] + us[i + 1]);
        for (uint32_t j = 0; j + 1 < nv; ++j) {
            double mv = 0.5 * (vs[j] + vs[j + 1]);
            int in = 0;
            for (uint32_t k = 0; k < g->count && !in; ++k)
                in = mu >= g->quads[k].u0 && mu <= g->quads[k].u1 && mv >= g->quads[k].v0 && mv <= g->quads[k].v1;
            if (!in)
                return 0;
        }
    }
    return 1;
}

/* ---- the proof ---------------------------------------------------------------------------- */

/* 1 when the plane x[a] = p lies strictly between E and B (with OCC_SEP to spare). */
static int separates(const vis_occ_box *e, const vis_occ_box *b, uint32_t a, double p)
{
    return (e->hi[a] <= p - OCC_SEP && b->lo[a] >= p + OCC_SEP) || (b->hi[a] <= p - OCC_SEP && e->lo[a] >= p + OCC_SEP);
}

/* The rectangle where segments from E to B cross x[a] = p (separates() holds). */
static occ_rect crossing_rect(const vis_occ_box *e, const vis_occ_box *b, uint32_t a, double p)
{
    uint32_t ax[2] = {a == 2 ? 0u : a + 1u, a == 0 ? 2u : a - 1u};
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    double cmax = fabs(p);
    for (int i = 0; i < 4; ++i) {
        double ea = (i & 1) ? e->hi[a] : e->lo[a], ba = (i & 2) ? b->hi[a] : b->lo[a];
        double s = (p - ea) / (ba - ea);
        for (int k = 0; k < 2; ++k) {
            uint32_t u = ax[k];
            for (int j = 0; j < 4; ++j) {
                double eu = (j & 1) ? e->hi[u] : e->lo[u], bu = (j & 2) ? b->hi[u] : b->lo[u];
                double x = eu + s * (bu - eu);
                if (x < lo[k])
                    lo[k] = x;
                if (x > hi[k])
                    hi[k] = x;
                if (fabs(x) > cmax)
                    cmax = fabs(x);
            }
        }
    }
    double tol = occ_tolerance(cmax);
    occ_rect r = {lo[0] - tol, lo[1] - tol, hi[0] + tol, hi[1] + tol};
    return r;
}

static int plane_covers(const vis_scene_view *view, const vis_occ_box *e, const vis_occ_box *b, uint32_t a, double p)
{
    occ_gather g;
    gather_plane(&g, view, a, p, crossing_rect(e, b, a, p));
    return !g.overflow && g.count > 0 && covered(&g);
}

/* The solid-ground test of plane x[a] = p (see the top of this file): 1 when the caller says
 * the box of cells around R is solid. */
static int solid_covers(const vis_occ_solid *solid, const vis_occ_box *e, const vis_occ_box *b, uint32_t a, double p,
                        uint64_t *tests)
{
    occ_rect r = crossing_rect(e, b, a, p);
    uint32_t u = a == 2 ? 0u : a + 1u, v = a == 0 ? 2u : a - 1u;
    double lo[3], hi[3];
    lo[a] = p - 1.0;
    hi[a] = p + 1.0;
    lo[u] = ceil(r.u0) - 1.0;
    hi[u] = floor(r.u1) + 1.0;
    lo[v] = ceil(r.v0) - 1.0;
    hi[v] = floor(r.v1) + 1.0;
    double cells = 1.0;
    int32_t ilo[3], ihi[3];
    for (int k = 0; k < 3; ++k) {
        /* Scene-local coordinates are floats of at most 2^24 or so; anything else is no box. */
        if (!(lo[k] >= -2147483648.0 && hi[k] <= 2147483647.0 && lo[k] < hi[k]))
            return 0;
        cells *= hi[k] - lo[k];
        ilo[k] = (int32_t)lo[k];
        ihi[k] = (int32_t)hi[k];
    }
    if (cells > (double)VIS_QUERY_SOLID_MAX_CELLS)
        return 0;
    ++*tests;
    return solid->fn(solid->user, ilo, ihi) == 1;
}

static void centre(const vis_occ_box *x, double c[3])
{
    for (int i = 0; i < 3; ++i)
        c[i] = 0.5 * (x->lo[i] + x->hi[i]);
}

static int straddles(const vis_occ_box *x, uint32_t a, double p)
{
    return x->lo[a] < p && x->hi[a] > p + 2.0 * OCC_SEP;
}

/* Cuts x on the plane: *x keeps [lo, p + sep], *y gets [p + sep, hi]. */
static void split_at(vis_occ_box *x, vis_occ_box *y, uint32_t a, double p)
{
    *y = *x;
    x->hi[a] = p + OCC_SEP;
    y->lo[a] = p + OCC_SEP;
}

static void split_half(vis_occ_box *x, vis_occ_box *y)
{
    uint32_t a = 0;
    for (uint32_t i = 1; i < 3; ++i)
        if (x->hi[i] - x->lo[i] > x->hi[a] - x->lo[a])
            a = i;
    double m = 0.5 * (x->lo[a] + x->hi[a]);
    *y = *x;
    x->hi[a] = m;
    y->lo[a] = m;
}

static double extent(const vis_occ_box *x)
{
    double m = 0.0;
    for (int i = 0; i < 3; ++i)
        if (x->hi[i] - x->lo[i] > m)
            m = x->hi[i] - x->lo[i];
    return m;
}

vis_occ_result vis_occ_test(const vis_scene_view *view, const vis_occ_box *eye, const vis_occ_box *target,
                            uint32_t limit, const vis_occ_solid *solid, uint32_t *rays, uint64_t *solid_tests,
                            double witness[6])
{
    if (solid && !solid->fn)
        solid = NULL;
    vis_occ_box st_e[OCC_STACK], st_b[OCC_STACK];
    int sp = 0;
    st_e[sp] = *eye;
    st_b[sp] = *target;
    ++sp;
    uint32_t spent = 0;
    vis_occ_result result = VIS_OCC_HIDDEN;
    while (sp > 0) {
        if (spent >= limit) {
            result = VIS_OCC_UNKNOWN;
            break;
        }
        --sp;
        vis_occ_box e = st_e[sp], b = st_b[sp];
        double ce[3], cb[3], x[3];
        centre(&e, ce);
        centre(&b, cb);
        ++spent;
        if (vis_occ_segment_clear(view, ce, cb, x)) {
            result = VIS_OCC_SEEN;
            if (witness) {
                memcpy(witness, ce, sizeof ce);
                memcpy(witness + 3, cb, sizeof cb);
            }
            break;
        }
        /* The planes of the first hits along the segment (a voxel quad lies in an integer
         * plane): the nearest wall may end inside R where a farther one covers it, so up
         * to OCC_HITS hits are tried, each further one costing a ray. */
        int proven = 0, cut = 0;
        double s_fail = -1.0; /* where an uncovered separating plane crossed: 0 at E, 1 at B */
        for (int hit = 0; hit < OCC_HITS && !proven && !cut; ++hit) {
            if (hit > 0) {
                double d[3] = {cb[0] - x[0], cb[1] - x[1], cb[2] - x[2]};
                double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]), from[3], prev[3];
                if (!(len > 4e-3) || spent >= limit)
                    break;
                for (int k = 0; k < 3; ++k)
                    from[k] = x[k] + d[k] / len * 2e-3;
                memcpy(prev, x, sizeof prev);
                ++spent;
                if (segment_raw(view, from, cb, x))
                    break; /* nothing more on the way to B's centre */
                if (solid) {
                    /* Between two hits: inside a hill, when they are where the segment
                     * enters and leaves it. */
                    uint32_t m = 0;
                    for (uint32_t k = 1; k < 3; ++k)
                        if (fabs(x[k] - prev[k]) > fabs(x[m] - prev[m]))
                            m = k;
                    double p = floor(0.5 * (prev[m] + x[m]) + 0.5);
                    if (fabs(x[m] - prev[m]) >= 2.0 && separates(&e, &b, m, p) &&
                        solid_covers(solid, &e, &b, m, p, solid_tests)) {
                        proven = 1;
                        break;
                    }
                }
            }
            for (uint32_t a = 0; a < 3 && !proven && !cut; ++a) {
                double p = floor(x[a] + 0.5);
                if (!(fabs(x[a] - p) <= 1e-3))
                    continue;
                if (separates(&e, &b, a, p)) {
                    if (spent >= limit)
                        break;
                    ++spent;
                    proven = plane_covers(view, &e, &b, a, p);
                    if (!proven && s_fail < 0.0)
                        s_fail = (p - ce[a]) / (cb[a] - ce[a]);
                } else if (hit == 0 && sp + 2 <= OCC_STACK && (straddles(&b, a, p) || straddles(&e, a, p))) {
                    /* Cut the straddling piece on the plane: each part then lies on one side. */
                    vis_occ_box *piece = straddles(&b, a, p) ? &b : &e;
                    vis_occ_box other;
                    split_at(piece, &other, a, p);
                    st_e[sp] = e;
                    st_b[sp] = b;
                    ++sp;
                    st_e[sp] = piece == &b ? e : other;
                    st_b[sp] = piece == &b ? other : b;
                    ++sp;
                    cut = 1;
                }
            }
        }
        if (proven || cut)
            continue;
        if (sp + 2 > OCC_STACK) {
            result = VIS_OCC_UNKNOWN;
            break;
        }
        /* Halve the piece that widens the uncovered rectangle more: a piece's extent reaches
         * the plane scaled by (1 - s) from E and by s from B. */
        vis_occ_box other;
        double we = extent(&e), wb = extent(&b);
        if (s_fail >= 0.0 && s_fail <= 1.0) {
            we *= 1.0 - s_fail;
            wb *= s_fail;
        }
        int cut_b = wb >= we;
        split_half(cut_b ? &b : &e, &other);
        st_e[sp] = e;
        st_b[sp] = b;
        ++sp;
        st_e[sp] = cut_b ? e : other;
        st_b[sp] = cut_b ? other : b;
        ++sp;
    }
    *rays += spent;
    return result;
}
