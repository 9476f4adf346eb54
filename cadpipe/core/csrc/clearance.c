/* Where a tube comes back to itself: the segment pairs of a batch of paths that lie
 * within reach of each other although the path between them turns by a right angle or
 * more (cadpipe.geometry.clearance explains why that is the test). */
#include "native.h"
#include "distance.h"
#include "tree.h"

typedef struct {
    const double *start, *seg, *reach, *turning, *total;
    const npy_bool *usable, *closed;
    const int64_t *tube, *next;
    int64_t n;
    double right_angle;
    double *lo, *hi;              /* (nodes, 3) boxes of the segments widened by reach */
    int depth;
} Segments;

/* The columns [lo, hi] under a node (hi < lo: none). */
static inline void node_columns(const Segments *g, int64_t node, int64_t *lo, int64_t *hi)
{
    int64_t first, count;
    tree_leaves(node, g->depth, &first, &count);
    *lo = first;
    *hi = first + count - 1 < g->n - 1 ? first + count - 1 : g->n - 1;
}

/* Whether no pair of columns of nodes a (columns la..ha) and b (lb..hb, la <= lb) can
 * hold a fold: both in one tube and the stretch of path joining them turning by less
 * than a right angle (around a closed tube, the other way too), or in different tubes
 * each. */
static inline int cannot_fold(const Segments *g, int64_t la, int64_t ha, int64_t lb, int64_t hb)
{
    int64_t ta = g->tube[la], tb = g->tube[hb];
    int one = ta == g->tube[ha] && tb == g->tube[lb];
    if (!one)
        return 0;
    if (ta != tb)
        return 1;
    double most = g->turning[ha > hb ? ha : hb] - g->turning[la];
    double least = lb > ha ? g->turning[lb] - g->turning[ha] : 0.0;
    return most < g->right_angle || (g->closed[ta] && g->total[ta] - least < g->right_angle);
}

static inline int boxes_apart(const Segments *g, int64_t a, int64_t b)
{
    for (int r = 0; r < 3; r++)
        if (g->lo[3 * a + r] > g->hi[3 * b + r] || g->lo[3 * b + r] > g->hi[3 * a + r])
            return 1;
    return 0;
}

/* Growable (i, j, distance) output. */
typedef struct {
    int64_t *i, *j;
    double *d;
    int64_t count, room;
} Found;

static int found_push(Found *f, int64_t i, int64_t j, double d)
{
    if (f->count == f->room) {
        int64_t room = f->room ? 2 * f->room : 1024;
        int64_t *ni = realloc(f->i, room * sizeof *ni), *nj = ni ? realloc(f->j, room * sizeof *nj)
                                                                 : NULL;
        double *nd = nj ? realloc(f->d, room * sizeof *nd) : NULL;
        if (ni)
            f->i = ni;
        if (nj)
            f->j = nj;
        if (!nd)
            return 0;
        f->d = nd;
        f->room = room;
    }
    f->i[f->count] = i, f->j[f->count] = j, f->d[f->count] = d;
    f->count++;
    return 1;
}

/* A leaf pair: real segments of one tube, not neighbours, closer than their reaches. */
static inline int leaf_pair(const Segments *g, int64_t i, int64_t j, Found *found,
                            int64_t *spent, int64_t budget, int64_t *over)
{
    if (i == j || g->tube[i] != g->tube[j] || !g->usable[i] || !g->usable[j] ||
        g->next[i] == j || g->next[j] == i)
        return 1;
    if (cannot_fold(g, i, i, j, j))
        return 1;
    double s, t;
    V3 p = v3_at(g->start + 3 * i), u = v3_at(g->seg + 3 * i);
    V3 q = v3_at(g->start + 3 * j), v = v3_at(g->seg + 3 * j);
    segments_closest(p, u, q, v, &s, &t);
    double d = sqrt(v3_norm2(v3_sub(v3_add(p, v3_scale(u, s)), v3_add(q, v3_scale(v, t)))));
    if (!(d < g->reach[i] + g->reach[j]))
        return 1;
    if (!found_push(found, i, j, d))
        return 0;
    if (++spent[g->tube[i]] > budget && *over < 0)
        *over = g->tube[i];
    return 1;
}

/* near_segment_pairs(start (N, 3), seg (N, 3), reach (N,), usable (N,) bool, tube (N,),
 * next (N,), turning (N,) cumulative, closed (T,) bool, total (T,), right_angle, budget)
 * -> (i, j, distance, over): the column pairs i < j within reach of each other where
 * the tube may fold (see cannot_fold; then distance < reach[i] + reach[j]), found by
 * walking a tree of the segments' boxes against itself, in no particular order; the walk
 * stops once a tube has more than ``budget`` pairs (``over`` is that tube, else -1). */
KERNEL(near_segment_pairs)
{
    CP_NARGS(11);
    IN_F64(0, start, 2);
    IN_F64(1, seg, 2);
    IN_F64(2, reach, 1);
    IN_BOOL(3, usable, 1);
    IN_I64(4, tube, 1);
    IN_I64(5, next, 1);
    IN_F64(6, turning, 1);
    IN_BOOL(7, closed, 1);
    IN_F64(8, total, 1);
    IN_DOUBLE(9, right_angle);
    IN_LONG(10, budget);
    Segments g = {F64(start), F64(seg), F64(reach), F64(turning), F64(total), BOOL(usable),
                  BOOL(closed), I64(tube), I64(next), start.shape[0], right_angle};
    int64_t n = g.n;
    g.depth = tree_depth(n > 0 ? n : 1);
    int64_t leaves = (int64_t)1 << g.depth, nodes = 2 * leaves - 1;
    g.lo = malloc(sizeof(double) * 3 * nodes);
    g.hi = malloc(sizeof(double) * 3 * nodes);
    int64_t *stack = malloc(sizeof(int64_t) * 2 * (4 * (int64_t)g.depth + 8));
    int64_t *spent = calloc(total.size ? total.size : 1, sizeof(int64_t));
    Found found = {NULL, NULL, NULL, 0, 0};
    int ok = g.lo && g.hi && stack && spent;
    int64_t over_tube = -1;
    if (ok) {
        Py_BEGIN_ALLOW_THREADS
        for (int64_t k = 0; k < leaves; k++) {          /* leaf boxes: segment +- reach */
            double *lo = g.lo + 3 * (leaves - 1 + k), *hi = g.hi + 3 * (leaves - 1 + k);
            for (int r = 0; r < 3; r++) {
                if (k < n) {
                    double a = g.start[3 * k + r], b = a + g.seg[3 * k + r];
                    lo[r] = (a < b ? a : b) - g.reach[k];
                    hi[r] = (a < b ? b : a) + g.reach[k];
                } else {
                    lo[r] = INFINITY, hi[r] = -INFINITY;
                }
            }
        }
        for (int64_t k = leaves - 2; k >= 0; k--)
            for (int r = 0; r < 3; r++) {
                g.lo[3 * k + r] = cp_min(g.lo[3 * (2 * k + 1) + r], g.lo[3 * (2 * k + 2) + r]);
                g.hi[3 * k + r] = cp_max(g.hi[3 * (2 * k + 1) + r], g.hi[3 * (2 * k + 2) + r]);
            }
        int64_t top = 0, first_leaf = leaves - 1;
        if (n > 1) {
            stack[0] = 0, stack[1] = 0;
            top = 1;
        }
        while (top && ok && over_tube < 0) {
            top--;
            int64_t a = stack[2 * top], b = stack[2 * top + 1], la, ha, lb, hb;
            node_columns(&g, a, &la, &ha);
            node_columns(&g, b, &lb, &hb);
            if (ha < la || hb < lb || (a != b && boxes_apart(&g, a, b)))
                continue;
            if (cannot_fold(&g, la, ha, lb, hb))
                continue;
            if (a >= first_leaf && b >= first_leaf) {
                ok = leaf_pair(&g, la, lb, &found, spent, budget, &over_tube);
                continue;
            }
            if (a == b) {                           /* a node against itself */
                int64_t c = 2 * a + 1;
                stack[2 * top] = c, stack[2 * top + 1] = c + 1;
                stack[2 * top + 2] = c + 1, stack[2 * top + 3] = c + 1;
                stack[2 * top + 4] = c, stack[2 * top + 5] = c;
                top += 3;
                continue;
            }
            /* the larger node's children (a leaf stays), in column order */
            double size_a = 0.0, size_b = 0.0;
            for (int r = 0; r < 3; r++) {
                size_a += g.hi[3 * a + r] - g.lo[3 * a + r];
                size_b += g.hi[3 * b + r] - g.lo[3 * b + r];
            }
            if (b >= first_leaf || (a < first_leaf && size_a >= size_b)) {
                stack[2 * top] = 2 * a + 2, stack[2 * top + 1] = b;
                stack[2 * top + 2] = 2 * a + 1, stack[2 * top + 3] = b;
            } else {
                stack[2 * top] = a, stack[2 * top + 1] = 2 * b + 2;
                stack[2 * top + 2] = a, stack[2 * top + 3] = 2 * b + 1;
            }
            top += 2;
        }
        Py_END_ALLOW_THREADS
    }
    free(g.lo), free(g.hi), free(stack), free(spent);
    PyObject *result = NULL;
    if (ok) {
        npy_intp dims[1] = {found.count};
        PyArrayObject *i = cp_new(1, dims, NPY_INT64), *j = cp_new(1, dims, NPY_INT64);
        PyArrayObject *d = cp_new(1, dims, NPY_FLOAT64);
        if (i && j && d) {
            if (found.count) {
                memcpy(PyArray_DATA(i), found.i, found.count * sizeof(int64_t));
                memcpy(PyArray_DATA(j), found.j, found.count * sizeof(int64_t));
                memcpy(PyArray_DATA(d), found.d, found.count * sizeof(double));
            }
            result = Py_BuildValue("NNNL", i, j, d, (long long)over_tube);
        } else {
            Py_XDECREF(i), Py_XDECREF(j), Py_XDECREF(d);
        }
    } else {
        PyErr_NoMemory();
    }
    free(found.i), free(found.j), free(found.d);
    return result;
}

static PyMethodDef clearance_methods[] = {
    ENTRY(near_segment_pairs, "(start, seg, reach, usable, tube, next, turning, closed, total,"
                              " right_angle, budget) -> (i, j, distance, over_tube)"),
    END_ENTRIES};
