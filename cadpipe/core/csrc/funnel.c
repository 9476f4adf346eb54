/* The bounding-volume funnel: place objects, then test pairs, cheapest volume first
 * (cadpipe.collision.funnel explains the stages; cadpipe.collision.bounds the arithmetic).
 * Each test errs towards "overlap", so a pair a stage calls apart is apart. Needs
 * convex.c, packed.c and narrow.c before it. */
#include "native.h"
#include "collision.h"

/* 64 units in the last place of 1 (numpy's 64 * finfo(float).eps): rounding per placed
 * coordinate */
#define EPS64 0x1p-46

/* Object ``i`` (its support points ``points[starts[i]:starts[i + 1]]`` (3 each) padded by
 * ``pads``, rounding slack ``slack[i]``, local OBB ``obb_centre`` (3), ``obb_axes`` (3, 3))
 * at pose ``m`` (4, 4): its world 18-DOP ``kdop`` (2, 9), OBB centre (3) and axes (3, 3). */
static void place_one(const double *points, const double *pads, const int64_t *starts,
                      const double *slack, const double *obb_centre, const double *obb_axes,
                      int64_t i, const double *m, double *kdop, double *centre, double *axes)
{
    double margin = slack[i] + EPS64 * cp_max(cp_max(fabs(m[3]), fabs(m[7])), fabs(m[11]));
    /* each world direction turned into the object's frame; the support points are the
     * outer loop, so the 18 running extremes are independent of each other */
    double u[9][3], lo[9], hi[9];
    for (int d = 0; d < 9; d++) {
        const double *k = KDOP_DIRECTIONS[d];
        for (int c = 0; c < 3; c++)
            u[d][c] = k[0] * m[c] + k[1] * m[4 + c] + k[2] * m[8 + c];
        lo[d] = INFINITY, hi[d] = -INFINITY;
    }
    for (int64_t s = starts[i]; s < starts[i + 1]; s++) {
        double x = points[3 * s], y = points[3 * s + 1], z = points[3 * s + 2], pad = pads[s];
        for (int d = 0; d < 9; d++) {
            double p = u[d][0] * x + u[d][1] * y + u[d][2] * z;
            lo[d] = cp_min(lo[d], p - pad);
            hi[d] = cp_max(hi[d], p + pad);
        }
    }
    for (int d = 0; d < 9; d++) {
        const double *k = KDOP_DIRECTIONS[d];
        double offset = k[0] * m[3] + k[1] * m[7] + k[2] * m[11];
        kdop[d] = lo[d] + offset - margin;
        kdop[9 + d] = hi[d] + offset + margin;
    }
    const double *oc = obb_centre + 3 * i, *oa = obb_axes + 9 * i;
    for (int r = 0; r < 3; r++) {
        const double *row = m + 4 * r;
        centre[r] = row[3] + row[0] * oc[0] + row[1] * oc[1] + row[2] * oc[2];
        for (int c = 0; c < 3; c++)
            axes[3 * r + c] = row[0] * oa[c] + row[1] * oa[3 + c] + row[2] * oa[6 + c];
    }
}

/* Whether ``axis`` (3) separates two boxes (axes as columns of ``xa``, ``xb``, half extents
 * ``ha``, ``hb``) whose centres are ``offset`` apart, by more than ``slack``. */
static inline int apart_on(const double *axis, const double *offset, const double *xa,
                           const double *ha, const double *xb, const double *hb, double slack)
{
    double gap = fabs(axis[0] * offset[0] + axis[1] * offset[1] + axis[2] * offset[2]);
    double reach = 0.0;
    for (int c = 0; c < 3; c++) {
        reach += ha[c] * fabs(axis[0] * xa[c] + axis[1] * xa[3 + c] + axis[2] * xa[6 + c]);
        reach += hb[c] * fabs(axis[0] * xb[c] + axis[1] * xb[3 + c] + axis[2] * xb[6 + c]);
    }
    return gap > reach + slack;
}

/* The separating-axis test of two placed OBBs (centre (3), axes as columns (3, 3), half
 * extents (3)): the 15 axes of Gottschalk et al. 1996. */
static int obb_apart(const double *ca, const double *xa, const double *ha, const double *cb,
                     const double *xb, const double *hb)
{
    double offset[3] = {cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2]};
    double size = 0.0;
    for (int r = 0; r < 3; r++)
        size += fabs(offset[r]) + ha[r] + hb[r];
    double slack = 1e-12 * size;
    for (int c = 0; c < 3; c++) {
        double a[3] = {xa[c], xa[3 + c], xa[6 + c]}, b[3] = {xb[c], xb[3 + c], xb[6 + c]};
        if (apart_on(a, offset, xa, ha, xb, hb, slack) ||
            apart_on(b, offset, xa, ha, xb, hb, slack))
            return 1;
    }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double a[3] = {xa[i], xa[3 + i], xa[6 + i]}, b[3] = {xb[j], xb[3 + j], xb[6 + j]};
            double axis[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                              a[0] * b[1] - a[1] * b[0]};
            if (apart_on(axis, offset, xa, ha, xb, hb, slack))
                return 1;
        }
    return 0;
}

/* The first bounding volume that proves slots ``a`` and ``b`` of ``kdop`` (R, 2, 9),
 * ``centre`` (R, 3), ``axes`` (R, 3, 3) apart (AABB, KDOP, OBB; ``half_a``, ``half_b`` their
 * OBBs' half extents), or NARROW. */
static inline int bounds_apart(const double *kdop, const double *centre, const double *axes,
                               const double *half_a, const double *half_b, int64_t a, int64_t b)
{
    const double *ka = kdop + 18 * a, *kb = kdop + 18 * b;
    for (int d = 0; d < 9; d++)
        if (ka[d] > kb[9 + d] || kb[d] > ka[9 + d])
            return d < 3 ? AABB : KDOP;
    if (obb_apart(centre + 3 * a, axes + 9 * a, half_a, centre + 3 * b, axes + 9 * b, half_b))
        return OBB;
    return NARROW;
}

/* Whether the convex pieces prove objects ``i`` and ``j`` at poses ``m_i``, ``m_j`` apart (a
 * lower bound of body_bounds above 0, in FUNNEL_ITERATIONS steps). */
static inline int hulls_apart(const Pieces *p, int64_t i, const double *m_i, int64_t j,
                              const double *m_j)
{
    double best, least;
    body_bounds(p->points, p->pads, p->piece_starts, p->centre, p->radius, p->pieces, i, m_i, j,
                m_j, 0.0, FUNNEL_ITERATIONS, &best, &least);
    return best > 0.0;
}

/* Whether the 6 arrays of ``pieces`` (a tuple, checked by pieces_of) fit together for ``n``
 * objects: offsets that rise within the arrays they index. */
static int pieces_fit(PyObject *pieces, npy_intp n)
{
    PyArrayObject **a = (PyArrayObject **)((PyTupleObject *)pieces)->ob_item;
    npy_intp points = PyArray_DIM(a[0], 0), count = PyArray_DIM(a[2], 0) - 1;
    if (PyArray_DIM(a[1], 0) != points || count < 0 || PyArray_DIM(a[3], 0) != count ||
        PyArray_DIM(a[3], 1) != 3 || PyArray_DIM(a[4], 0) != count ||
        PyArray_DIM(a[5], 0) != n + 1 || PyArray_DIM(a[0], 1) != 3 ||
        !offsets_ok(PyArray_DATA(a[2]), count, points) ||
        !offsets_ok(PyArray_DATA(a[5]), n, count)) {
        PyErr_SetString(PyExc_ValueError, "decide_pairs: pieces that do not fit together");
        return 0;
    }
    return 1;
}

/* place_bounds(points, pads, starts, slack, obb_centre, obb_axes, ids (E,), poses (E, 4, 4),
 * kdop (R, 2, 9), centre (R, 3), axes (R, 3, 3), rows (E,)): objects ids at poses into rows
 * rows (cadpipe.collision.funnel.place) */
KERNEL(place_bounds)
{
    CP_NARGS(12);
    IN_F64(0, points, 2);
    IN_F64(1, pads, 1);
    IN_I64(2, starts, 1);
    IN_F64(3, slack, 1);
    IN_F64(4, obb_centre, 2);
    IN_F64(5, obb_axes, 3);
    IN_I64(6, ids, 1);
    IN_F64(7, poses, 3);
    OUT_F64(8, kdop, 3);
    OUT_F64(9, centre, 2);
    OUT_F64(10, axes, 3);
    IN_I64(11, rows, 1);
    npy_intp n = slack.shape[0], count = ids.shape[0], room = kdop.shape[0];
    if (points.shape[1] != 3 || pads.shape[0] != points.shape[0] || starts.shape[0] != n + 1 ||
        obb_centre.shape[0] != n || obb_centre.shape[1] != 3 || obb_axes.shape[0] != n ||
        obb_axes.size != 9 * n || poses.shape[0] != count || poses.shape[1] != 4 ||
        poses.shape[2] != 4 || kdop.size != 18 * room || centre.shape[0] != room ||
        centre.shape[1] != 3 || axes.shape[0] != room || axes.size != 9 * room ||
        rows.shape[0] != count || !offsets_ok(I64(starts), n, points.shape[0])) {
        PyErr_SetString(PyExc_ValueError, "place_bounds: shapes differ");
        return NULL;
    }
    for (npy_intp e = 0; e < count; e++)
        if (I64(ids)[e] < 0 || I64(ids)[e] >= n || I64(rows)[e] < 0 || I64(rows)[e] >= room) {
            PyErr_SetString(PyExc_IndexError, "place_bounds: an object or row not there");
            return NULL;
        }
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp e = 0; e < count; e++) {
        int64_t row = I64(rows)[e];
        place_one(F64(points), F64(pads), I64(starts), F64(slack), F64(obb_centre),
                  F64(obb_axes), I64(ids)[e], F64(poses) + 16 * e, F64(kdop) + 18 * row,
                  F64(centre) + 3 * row, F64(axes) + 9 * row);
    }
    Py_END_ALLOW_THREADS
    Py_RETURN_NONE;
}

/* decide_pairs(kdop (R, 2, 9), centre (R, 3), axes (R, 3, 3), half_of (R, 3), slot_a (E,),
 * slot_b (E,), pieces (the 6 arrays of Pieces.arrays(), or None: no hull stage), chain (N,),
 * object_of (R,), slot_poses (R, 4, 4), codes (E,) int8): per entry the first stage that
 * proves its slots apart, or NARROW (cadpipe.collision.funnel.decide) */
KERNEL(decide_pairs)
{
    CP_NARGS(11);
    IN_F64(0, kdop, 3);
    IN_F64(1, centre, 2);
    IN_F64(2, axes, 3);
    IN_F64(3, half_of, 2);
    IN_I64(4, slot_a, 1);
    IN_I64(5, slot_b, 1);
    Pieces pieces = {NULL, NULL, NULL, NULL, NULL, NULL};
    int hulls = args[6] != Py_None;
    if (hulls && (!PyTuple_Check(args[6]) || PyTuple_GET_SIZE(args[6]) != 6)) {
        cp_fail("decide_pairs", 6, "None or the 6 arrays of Pieces.arrays()", args[6]);
        return NULL;
    }
    if (hulls && !pieces_of(((PyTupleObject *)args[6])->ob_item, &pieces, "decide_pairs", 0))
        return NULL;
    IN_BOOL(7, chain, 1);
    IN_I64(8, object_of, 1);
    IN_F64(9, slot_poses, 3);
    OUT_I8(10, codes, 1);
    npy_intp room = kdop.shape[0], count = slot_a.shape[0], n = chain.shape[0];
    if (hulls && !pieces_fit(args[6], n))
        return NULL;
    if (kdop.size != 18 * room || centre.shape[0] != room || centre.shape[1] != 3 ||
        axes.shape[0] != room || axes.size != 9 * room || half_of.shape[0] != room ||
        half_of.shape[1] != 3 || slot_b.shape[0] != count || object_of.shape[0] != room ||
        slot_poses.shape[0] != room || slot_poses.size != 16 * room || codes.shape[0] != count) {
        PyErr_SetString(PyExc_ValueError, "decide_pairs: shapes differ");
        return NULL;
    }
    for (npy_intp k = 0; k < count; k++)
        if (I64(slot_a)[k] < 0 || I64(slot_a)[k] >= room || I64(slot_b)[k] < 0 ||
            I64(slot_b)[k] >= room) {
            PyErr_SetString(PyExc_IndexError, "decide_pairs: a slot not there");
            return NULL;
        }
    for (npy_intp r = 0; r < room; r++)
        if (I64(object_of)[r] < 0 || I64(object_of)[r] >= n) {
            PyErr_SetString(PyExc_IndexError, "decide_pairs: an object not there");
            return NULL;
        }
    const double *k_ = F64(kdop), *c_ = F64(centre), *x_ = F64(axes), *h_ = F64(half_of);
    const double *poses = F64(slot_poses);
    const int64_t *object = I64(object_of);
    const npy_bool *is_chain = BOOL(chain);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp k = 0; k < count; k++) {
        int64_t a = I64(slot_a)[k], b = I64(slot_b)[k], i = object[a], j = object[b];
        int found = bounds_apart(k_, c_, x_, h_ + 3 * a, h_ + 3 * b, a, b);
        if (found == NARROW && hulls && !(is_chain[i] || is_chain[j]) &&
            hulls_apart(&pieces, i, poses + 16 * a, j, poses + 16 * b))
            found = HULL;
        I8(codes)[k] = (int8_t)found;
    }
    Py_END_ALLOW_THREADS
    Py_RETURN_NONE;
}

/* Whether pair ``k``'s stored answer is as new as its objects' poses. */
static inline int holds(const Packed *w, npy_intp k)
{
    return w->at_a[k] == w->versions[w->first[k]] && w->at_b[k] == w->versions[w->second[k]];
}

/* refresh(record, chosen (P,) bool, first_hit, stop_after_self, out_code (P,) int8,
 * out_colliding (P,) bool) -> how many pairs were left to Python: one state where the
 * objects stand (cadpipe.collision.funnel describes it). Objects whose pose version differs
 * from the one their bounds were placed at are placed again; every chosen pair whose answer
 * is older than its objects' poses goes down the funnel, self pairs first, each group in
 * pair order; chains are settled here (settle), the rest listed in the record's ``left``
 * with the relative pose in ``left_poses``; every answer found is stored in the record, and
 * ``hits`` says whether a chosen pair whose answer holds collides (a self pair, another).
 * The GIL is kept: a state takes microseconds, less than releasing it costs under load. */
KERNEL(refresh)
{
    CP_NARGS(6);
    Packed *w = packed_of(args, 0, "refresh");
    if (!w)
        return NULL;
    IN_BOOL(1, chosen_arr, 1);
    IN_FLAG(2, first_hit);
    IN_FLAG(3, stop_after_self);
    OUT_I8(4, out_code, 1);
    OUT_BOOL(5, out_colliding, 1);
    npy_intp n = w->n, pairs = w->p;
    if (chosen_arr.size != pairs || out_code.size != pairs || out_colliding.size != pairs) {
        PyErr_SetString(PyExc_ValueError, "refresh: chosen and the outputs need one per pair");
        return NULL;
    }
    const npy_bool *chosen = BOOL(chosen_arr);
    const int64_t *versions = w->versions;
    npy_bool *hits = w->hits;
    Pieces pieces = {w->piece_points, w->piece_pads, w->piece_centre, w->piece_radius,
                     w->piece_starts, w->pieces};
    for (npy_intp i = 0; i < n; i++)
        if (w->placed_at[i] != versions[i]) {
            place_one(w->points, w->pads, w->starts, w->slack, w->obb_centre, w->obb_axes, i,
                      w->poses + 16 * i, w->kdop + 18 * i, w->centre + 3 * i, w->axes + 9 * i);
            w->placed_at[i] = versions[i];
        }
    hits[0] = hits[1] = 0;
    if (first_hit)                       /* a collision already known answers at once */
        for (npy_intp k = 0; k < pairs; k++)
            if (chosen[k] && w->colliding[k] && holds(w, k))
                hits[w->same[k] ? 0 : 1] = 1;
    int64_t count = 0;
    for (int own = 1; own >= 0; own--) {
        for (npy_intp k = 0; k < pairs; k++) {
            if ((first_hit && (hits[0] || hits[1])) || (stop_after_self && !own && hits[0]))
                break;
            if (!chosen[k] || (w->same[k] != 0) != own)
                continue;
            int64_t a = w->first[k], b = w->second[k];
            if (holds(w, k)) {
                if (w->colliding[k])
                    hits[own ? 0 : 1] = 1;
                continue;
            }
            const double *pose_a = w->poses + 16 * a, *pose_b = w->poses + 16 * b;
            int found = bounds_apart(w->kdop, w->centre, w->axes, w->half + 3 * a,
                                     w->half + 3 * b, a, b);
            int touching = 0;
            if (found == NARROW && !w->certify) {
                if (!(w->chain[a] || w->chain[b]) && hulls_apart(&pieces, a, pose_a, b, pose_b))
                    found = HULL;
                else
                    found = settle(w, a, pose_a, b, pose_b, &touching);
                if (found == SETTLE_NO_MEMORY)
                    return PyErr_NoMemory();
            }
            if (found == NARROW) {
                w->left[count] = k;
                relative_poses(pose_a, pose_b, w->left_poses + 16 * count, 1);
                count++;
                continue;
            }
            w->code[k] = (int8_t)found, w->colliding[k] = (npy_bool)touching;
            w->at_a[k] = versions[a], w->at_b[k] = versions[b];
            if (touching)
                hits[own ? 0 : 1] = 1;
        }
    }
    int stopped = stop_after_self && hits[0];
    int8_t *codes = I8(out_code);
    npy_bool *colliding = BOOL(out_colliding);
    for (npy_intp k = 0; k < pairs; k++) {
        int held = chosen[k] && holds(w, k) && (w->same[k] || !stopped);
        codes[k] = w->allowed[k] ? ALLOWED : held ? w->code[k] : NOT_CHECKED;
        colliding[k] = held && w->colliding[k];
    }
    return PyLong_FromLongLong(count);
}

/* collision_constants() -> {name: value}: the stage codes and constants of collision.h, which
 * the Python modules check theirs against */
KERNEL(collision_constants)
{
    CP_NARGS(0);
    PyObject *directions = PyTuple_New(27);
    for (int k = 0; directions && k < 27; k++)
        PyTuple_SET_ITEM(directions, k, PyFloat_FromDouble(KDOP_DIRECTIONS[k / 3][k % 3]));
    if (!directions)
        return NULL;
    return Py_BuildValue("{sisisisisisisisisisisisisisisN}", "ALLOWED", ALLOWED, "AABB", AABB,
                         "KDOP", KDOP, "OBB", OBB, "HULL", HULL, "FCL", FCL, "CONTAINMENT",
                         CONTAINMENT, "ANALYTIC", ANALYTIC, "NOT_CHECKED", NOT_CHECKED,
                         "UNSETTLED", UNSETTLED, "NARROW", NARROW, "REFUSED", REFUSED,
                         "FUNNEL_ITERATIONS", FUNNEL_ITERATIONS, "SETTLE_LEFT", SETTLE_LEFT,
                         "KDOP_DIRECTIONS", directions);
}

static PyMethodDef funnel_methods[] = {
    ENTRY(place_bounds, "(points, pads, starts, slack, obb_centre, obb_axes, ids, poses, kdop,"
                        " centre, axes, rows): objects' 18-DOPs and OBBs at poses"),
    ENTRY(decide_pairs, "(kdop, centre, axes, half_of, slot_a, slot_b, pieces or None, chain,"
                        " object_of, slot_poses, codes): the funnel's stage per entry"),
    ENTRY(refresh, "(record, chosen, first_hit, stop_after_self, out_code, out_colliding)"
                   " -> pairs left: one state where the objects stand"),
    ENTRY(collision_constants, "() -> {name: value}: the collision kernels' codes"),
    END_ENTRIES};
