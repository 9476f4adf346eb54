/* The exact phase of one pair at one pose, where it needs no Python: two chains by their
 * capsule trees, a chain against a mesh by the triangle tree walk and the containment
 * prefilter (cadpipe.collision.narrow.settle). Needs transform.c, hierarchy.c,
 * chain_mesh.c and packed.c before it. */
#include "native.h"
#include "collision.h"

/* room for tapered unit pairs in settle's chain walk (more: left to Python) */
#define SETTLE_LEFT 64
/* what settle returns when it had no memory */
#define SETTLE_NO_MEMORY (-100)

/* Whether, moved by ``m`` (4, 4), some of the ``count`` ``probes`` (3 each) lies in the box
 * ``lo``, ``hi`` (3) and each of the ``extremes`` (3 each) within the 18-DOP ``low``,
 * ``high`` (9) widened by ``slack``: a solid that may lie inside a mesh. */
static int could_be_inside(const double *m, const double *probes, npy_intp count,
                           const double *extremes, npy_intp extreme_count, const double *lo,
                           const double *hi, const double *low, const double *high, double slack)
{
    int in_box = 0;
    for (npy_intp k = 0; k < count; k++) {
        const double *p = probes + 3 * k;
        int inside = 1;
        for (int r = 0; r < 3; r++) {
            double v = m[4 * r] * p[0] + m[4 * r + 1] * p[1] + m[4 * r + 2] * p[2] + m[4 * r + 3];
            inside = inside && lo[r] <= v && v <= hi[r];
        }
        in_box = in_box || inside;
    }
    int fits = in_box;
    for (npy_intp k = 0; k < extreme_count && fits; k++) {
        double e0 = extremes[3 * k], e1 = extremes[3 * k + 1], e2 = extremes[3 * k + 2];
        double x0 = m[0] * e0 + m[1] * e1 + m[2] * e2 + m[3];
        double x1 = m[4] * e0 + m[5] * e1 + m[6] * e2 + m[7];
        double x2 = m[8] * e0 + m[9] * e1 + m[10] * e2 + m[11];
        for (int d = 0; d < 9; d++) {
            const double *u = KDOP_DIRECTIONS[d];
            double v = u[0] * x0 + u[1] * x1 + u[2] * x2;
            fits = fits && low[d] - slack <= v && v <= high[d] + slack;
        }
    }
    return fits;
}

/* narrow.collide of objects ``i`` and ``j`` of the record ``w`` at poses ``pose_i``,
 * ``pose_j`` (4, 4): the code ANALYTIC (two chains), FCL (a chain and a mesh) or UNSETTLED
 * for what is left to Python (two meshes, a chain that may lie inside a mesh, tapered unit
 * pairs the walk does not settle, a mesh whose triangle tree is not packed), and whether
 * they touch into ``touching``; SETTLE_NO_MEMORY when there was no memory. The same walks
 * on the same relative pose as narrow.collide, so the same answers. */
static int settle(const Packed *w, int64_t i, const double *pose_i, int64_t j,
                  const double *pose_j, int *touching)
{
    double rel[16];
    *touching = 0;
    if (w->chain[i] && w->chain[j]) {
        relative_poses(pose_i, pose_j, rel, 1);
        double gap, params[2];
        int64_t units[2], left[3 * SETTLE_LEFT];
        int64_t a = w->tree_at[i], b = w->tree_at[j], points = w->tree_points_at[j];
        int64_t count = chain_walk(w->tree_table + 10 * a, w->tree_index + 3 * a,
                                   w->tree_depth[i], w->tree_points + 3 * points,
                                   w->tree_points_at[j + 1] - points, w->tree_table + 10 * b,
                                   w->tree_index + 3 * b, w->tree_depth[j], rel, 1, 0.0, 1,
                                   &gap, units, params, left, SETTLE_LEFT);
        if (count == -2)
            return SETTLE_NO_MEMORY;
        if (count < 0 || (count > 0 && gap > 0.0))   /* the round cones decide: Python */
            return UNSETTLED;
        *touching = gap <= 0.0;
        return ANALYTIC;
    }
    if (!(w->chain[i] || w->chain[j]))
        return UNSETTLED;
    int64_t mesh = w->chain[i] ? j : i, other = w->chain[i] ? i : j;
    int64_t boxes = w->boxes_at[mesh];
    if (boxes == w->boxes_at[mesh + 1])                /* no triangle tree packed */
        return UNSETTLED;
    if (w->chain[i])
        relative_poses(pose_j, pose_i, rel, 1);
    else
        relative_poses(pose_i, pose_j, rel, 1);
    double gap, near[3], far[3];
    int64_t unit, nodes = w->tree_at[other], points = w->tree_points_at[other];
    if (mesh_walk(w->mesh_boxes + 7 * boxes, w->mesh_frames + 15 * w->frames_at[mesh],
                  w->mesh_triangles + 9 * w->triangles_at[mesh], w->mesh_depth[mesh],
                  w->tree_table + 10 * nodes, w->tree_index + 3 * nodes,
                  w->tree_points + 3 * points, w->tree_at[other + 1] - nodes,
                  w->tree_depth[other], rel, 1, 1, &gap, &unit, near, far))
        return SETTLE_NO_MEMORY;
    if (gap <= 0.0) {
        *touching = 1;
        return FCL;
    }
    if (!w->closed[mesh])
        return FCL;
    int64_t probes = w->probes_at[other];
    int inside = could_be_inside(rel, w->probes + 3 * probes, w->probes_at[other + 1] - probes,
                                 w->extremes + 54 * other, 18, w->inside_lo + 3 * mesh,
                                 w->inside_hi + 3 * mesh, w->inside_low + 9 * mesh,
                                 w->inside_high + 9 * mesh, w->inside_slack[mesh]);
    return inside ? UNSETTLED : FCL;
}

/* could_be_inside(rel (E, 4, 4), probes (K, 3), extremes (X, 3), lo (3,), hi (3,), low (9,),
 * high (9,), slack, out (E,) bool) */
KERNEL(could_be_inside)
{
    CP_NARGS(9);
    IN_F64(0, rel, 3);
    IN_F64(1, probes, 2);
    IN_F64(2, extremes, 2);
    IN_F64(3, lo, 1);
    IN_F64(4, hi, 1);
    IN_F64(5, low, 1);
    IN_F64(6, high, 1);
    IN_DOUBLE(7, slack);
    OUT_BOOL(8, out, 1);
    npy_intp count = rel.shape[0];
    if (rel.shape[1] != 4 || rel.shape[2] != 4 || probes.shape[1] != 3 ||
        extremes.shape[1] != 3 || lo.size != 3 || hi.size != 3 || low.size != 9 ||
        high.size != 9 || out.size != count) {
        PyErr_SetString(PyExc_ValueError, "could_be_inside: shapes differ");
        return NULL;
    }
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp e = 0; e < count; e++)
        BOOL(out)[e] = (npy_bool)could_be_inside(F64(rel) + 16 * e, F64(probes), probes.shape[0],
                                                 F64(extremes), extremes.shape[0], F64(lo),
                                                 F64(hi), F64(low), F64(high), slack);
    Py_END_ALLOW_THREADS
    Py_RETURN_NONE;
}

/* An object index of the record, or -1 with an IndexError. */
static inline int64_t packed_object(const Packed *w, PyObject *o, int at)
{
    int64_t i;
    if (!cp_long(o, &i, "collide_pose", at))
        return -1;
    if (i < 0 || i >= w->n) {
        PyErr_Format(PyExc_IndexError, "collide_pose: no object %lld", (long long)i);
        return -1;
    }
    return i;
}

/* collide_pose(record, i, pose_i (4, 4), j, pose_j (4, 4)) -> (code, touching): settle of
 * objects i and j at those poses, each first checked as as_pose checks it (the code
 * REFUSED, and nothing decided, where one fails), in one call: checks of their own cost
 * more than a pipe-mesh walk. */
KERNEL(collide_pose)
{
    CP_NARGS(5);
    Packed *w = packed_of(args, 0, "collide_pose");
    if (!w)
        return NULL;
    int64_t i = packed_object(w, args[1], 1);
    if (i < 0)
        return NULL;
    IN_F64(2, pose_i, 2);
    int64_t j = packed_object(w, args[3], 3);
    if (j < 0)
        return NULL;
    IN_F64(4, pose_j, 2);
    if (pose_i.size != 16 || pose_j.size != 16) {
        PyErr_SetString(PyExc_ValueError, "collide_pose: poses are 4x4");
        return NULL;
    }
    int touching = 0, code = REFUSED;
    if (!stack_problem(F64(pose_i), 1, 1) && !stack_problem(F64(pose_j), 1, 1))
        code = settle(w, i, F64(pose_i), j, F64(pose_j), &touching);
    if (code == SETTLE_NO_MEMORY)
        return PyErr_NoMemory();
    return Py_BuildValue("(iO)", code, touching ? Py_True : Py_False);
}

static PyMethodDef narrow_methods[] = {
    ENTRY(could_be_inside, "(rel, probes, extremes, lo, hi, low, high, slack, out): the"
                           " containment prefilter per pose"),
    ENTRY(collide_pose, "(record, i, pose_i, j, pose_j) -> (code, touching): one pair at one"
                        " pose, the poses checked first (code -2: refused)"),
    END_ENTRIES};
