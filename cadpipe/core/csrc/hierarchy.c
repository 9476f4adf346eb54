/* Two chains' capsule trees walked against each other: the smallest unit-pair gap per pose
 * (cadpipe.collision.hierarchy explains the trees and the bounds). */
#include "native.h"
#include "distance.h"

/* The deepest tree a walk takes (2**62 leaves: no tree comes near it); its stacks are
 * fixed arrays of this bound. */
#define TREE_DEPTH_MAX 62
#define CHAIN_STACK (2 * (2 * TREE_DEPTH_MAX + 2))
/* a tree's points moved per pose go on the C stack up to this many (else malloc) */
#define CHAIN_POINTS_LOCAL 256

/* chain_gaps' walk of tree a (``table_a`` (Ta, 10), ``index_a`` (Ta, 3), ``depth_a``)
 * against tree b (its ``count_b`` ``points_b`` (K, 3), ``table_b``, ``index_b``,
 * ``depth_b``) moved by each of ``count`` ``poses`` (4, 4), depth first, splitting the larger
 * node of each pair. Per pose ``gap``, ``units`` (2), ``params`` (2) as
 * hierarchy.walk_trees documents; tapered leaf pairs go to ``left`` (room rows of pose,
 * unit, unit). Returns how many went there, -1 when ``left`` is too small, -2 when there
 * is no memory. */
static int64_t chain_walk(const double *table_a, const int64_t *index_a, int64_t depth_a,
                          const double *points_b, npy_intp count_b, const double *table_b,
                          const int64_t *index_b, int64_t depth_b, const double *poses,
                          npy_intp count, double cap, int yes_no, double *gap, int64_t *units,
                          double *params, int64_t *left, npy_intp room)
{
    int64_t leaves_a = ((int64_t)1 << depth_a) - 1, leaves_b = ((int64_t)1 << depth_b) - 1;
    double local[3 * CHAIN_POINTS_LOCAL];
    double *moved = local;
    if (count_b > CHAIN_POINTS_LOCAL && !(moved = malloc(sizeof(double) * 3 * count_b)))
        return -2;
    int64_t stack_a[CHAIN_STACK], stack_b[CHAIN_STACK];
    int64_t found = 0;
    for (npy_intp p = 0; p < count; p++) {
        move_points(poses + 16 * p, points_b, count_b, moved);
        double bound = INFINITY, best = INFINITY;
        units[2 * p] = -1, units[2 * p + 1] = -1, params[2 * p] = NAN, params[2 * p + 1] = NAN;
        stack_a[0] = 0, stack_b[0] = 0;
        int top = 1;
        while (top) {
            top--;
            int64_t na = stack_a[top], nb = stack_b[top];
            const double *fa = table_a + 10 * na, *fb = table_b + 10 * nb;
            /* the chords' closest points: a's in a's frame, b's moved */
            const double *e0 = moved + 3 * index_b[3 * nb], *e1 = moved + 3 * index_b[3 * nb + 1];
            double v0 = e1[0] - e0[0], v1 = e1[1] - e0[1], v2 = e1[2] - e0[2];
            double u0 = fa[3], u1 = fa[4], u2 = fa[5];
            double rx = fa[0] - e0[0], ry = fa[1] - e0[1], rz = fa[2] - e0[2];
            double uv = u0 * v0 + u1 * v1 + u2 * v2;
            double ur = u0 * rx + u1 * ry + u2 * rz;
            double vr = v0 * rx + v1 * ry + v2 * rz;
            double s, t;
            segment_params(fa[6], fb[6], uv, ur, vr, fa[7], fb[7], &s, &t);
            double dx = rx + s * u0 - t * v0, dy = ry + s * u1 - t * v1,
                   dz = rz + s * u2 - t * v2;
            double dist = sqrt(dx * dx + dy * dy + dz * dz);
            double upper = dist - fa[8] - fb[8];
            double lower = dist - fa[9] - fb[9];
            bound = cp_min(bound, cp_max(upper, 0.0));
            if (yes_no && bound <= cap)
                break;
            if (lower > (yes_no ? cap : cp_min(bound, best)))
                continue;
            int leaf_a = na >= leaves_a, leaf_b = nb >= leaves_b;
            if (leaf_a && leaf_b) {
                int64_t ua = index_a[3 * na + 2], ub = index_b[3 * nb + 2];
                if (fa[8] == fa[9] && fb[8] == fb[9]) {
                    if (lower < best) {           /* capsules: the gap is exact */
                        best = lower;
                        units[2 * p] = ua, units[2 * p + 1] = ub;
                        params[2 * p] = s, params[2 * p + 1] = t;
                    }
                    if (yes_no && best <= cap)
                        break;
                } else {
                    if (found == room) {
                        found = -1;
                        goto done;
                    }
                    left[3 * found] = p, left[3 * found + 1] = ua, left[3 * found + 2] = ub;
                    found++;
                }
                continue;
            }
            /* the larger node's children (by chord and outer radius; a leaf stays) */
            if (!leaf_a && (leaf_b || fa[6] + 4.0 * fa[9] * fa[9] >= fb[6] + 4.0 * fb[9] * fb[9])) {
                stack_a[top] = 2 * na + 2, stack_b[top] = nb;
                stack_a[top + 1] = 2 * na + 1, stack_b[top + 1] = nb;
            } else {
                stack_a[top] = na, stack_b[top] = 2 * nb + 2;
                stack_a[top + 1] = na, stack_b[top + 1] = 2 * nb + 1;
            }
            top += 2;
        }
        if (yes_no && cp_min(bound, best) <= cap) {  /* settled: no closest pair known */
            units[2 * p] = -1, units[2 * p + 1] = -1;
            params[2 * p] = NAN, params[2 * p + 1] = NAN;
        }
        gap[p] = yes_no ? cp_min(bound, best) : best;
    }
done:
    if (moved != local)
        free(moved);
    return found;
}

/* Whether ``table`` (T, 10) and ``index`` (T, 3) are a perfect capsule tree of ``depth``
 * whose chord ends index ``count`` points (any number when negative: not read); a
 * ValueError naming ``kernel`` otherwise. */
static int chain_tree_ok(const Arr *table, const Arr *index, int64_t depth, npy_intp count,
                         const char *kernel)
{
    if (depth < 0 || depth > TREE_DEPTH_MAX || table->shape[1] != 10 || index->shape[1] != 3 ||
        table->shape[0] != ((npy_intp)2 << depth) - 1 || index->shape[0] != table->shape[0]) {
        PyErr_Format(PyExc_ValueError, "%s: not a capsule tree of depth %lld", kernel,
                     (long long)depth);
        return 0;
    }
    const int64_t *at = I64(*index);
    for (npy_intp k = 0; count >= 0 && k < index->shape[0]; k++)
        if (at[3 * k] < 0 || at[3 * k] >= count || at[3 * k + 1] < 0 || at[3 * k + 1] >= count) {
            PyErr_Format(PyExc_ValueError, "%s: a chord end outside the tree's points", kernel);
            return 0;
        }
    return 1;
}

/* chain_walk(table_a, index_a, depth_a, points_b, table_b, index_b, depth_b, poses (P, 4, 4),
 * cap, yes_no, gap (P,), units (P, 2), params (P, 2), left (L, 3)) -> leaf pairs left, or
 * -1 when ``left`` is too small (cadpipe.collision.hierarchy.walk_trees) */
KERNEL(chain_walk)
{
    CP_NARGS(14);
    IN_F64(0, table_a, 2);
    IN_I64(1, index_a, 2);
    IN_LONG(2, depth_a);
    IN_F64(3, points_b, 2);
    IN_F64(4, table_b, 2);
    IN_I64(5, index_b, 2);
    IN_LONG(6, depth_b);
    IN_F64(7, poses, 3);
    IN_DOUBLE(8, cap);
    IN_FLAG(9, yes_no);
    OUT_F64(10, gap, 1);
    OUT_I64(11, units, 2);
    OUT_F64(12, params, 2);
    OUT_I64(13, left, 2);
    npy_intp count = poses.shape[0];
    if (!chain_tree_ok(&table_a, &index_a, depth_a, -1, "chain_walk") ||
        !chain_tree_ok(&table_b, &index_b, depth_b, points_b.shape[0], "chain_walk"))
        return NULL;
    if (points_b.shape[1] != 3 || poses.shape[1] != 4 || poses.shape[2] != 4 ||
        gap.shape[0] != count || units.shape[0] != count || units.shape[1] != 2 ||
        params.shape[0] != count || params.shape[1] != 2 || left.shape[1] != 3) {
        PyErr_SetString(PyExc_ValueError, "chain_walk: shapes differ");
        return NULL;
    }
    int64_t found;
    Py_BEGIN_ALLOW_THREADS
    found = chain_walk(F64(table_a), I64(index_a), depth_a, F64(points_b), points_b.shape[0],
                       F64(table_b), I64(index_b), depth_b, F64(poses), count, cap, yes_no,
                       F64(gap), I64(units), F64(params), I64(left), left.shape[0]);
    Py_END_ALLOW_THREADS
    if (found == -2)
        return PyErr_NoMemory();
    return PyLong_FromLongLong(found);
}

static PyMethodDef hierarchy_methods[] = {
    ENTRY(chain_walk, "(table_a, index_a, depth_a, points_b, table_b, index_b, depth_b, poses,"
                      " cap, yes_no, gap, units, params, left) -> leaf pairs left (-1: no room)"),
    END_ENTRIES};
