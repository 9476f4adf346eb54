/* Overlapping box pairs and crossing triangle pairs (cadpipe.geometry.intersect): the box
 * tree (tree.h's layout, built by boxtree.c) walked against itself, node pairs a <= b of
 * one level at a time, so each pair is met once; with the narrow phase, the triangle
 * pairs of overlapping leaf boxes tested as they are found. */
#include "native.h"
#include "tree.h"

/* The signed distance of ``point`` from the plane through ``origin`` with ``normal``. */
static inline double plane_at(const double *point, const double *origin, const double *normal)
{
    return (point[0] - origin[0]) * normal[0] + (point[1] - origin[1]) * normal[1] +
           (point[2] - origin[2]) * normal[2];
}

/* The three signed distances ``d`` are not all on one side (beyond ``tol``). */
static inline int straddles(const double *d, double tol)
{
    int above = d[0] > tol && d[1] > tol && d[2] > tol;
    int below = d[0] < -tol && d[1] < -tol && d[2] < -tol;
    return !(above || below);
}

/* Does an edge of triangle ``edges_of`` (9) cross the interior of ``target`` (9)? ``d``:
 * the signed distances of edges_of's corners from target's plane; ``normal``: its unit
 * normal. The crossing point must lie inside the target, beyond ``tol`` from each of its
 * sides. */
static int edges_pierce(const double *edges_of, const double *d, const double *target,
                        const double *normal, double tol)
{
    for (int e = 0; e < 3; e++) {
        double ds = d[e], de = d[(e + 1) % 3];
        if (!((ds > tol && de < -tol) || (ds < -tol && de > tol)))
            continue;
        double t = ds / (ds - de);
        const double *from = edges_of + 3 * e, *to = edges_of + 3 * ((e + 1) % 3);
        double point[3];
        for (int c = 0; c < 3; c++)
            point[c] = from[c] + t * (to[c] - from[c]);
        int inside = 1;
        for (int s = 0; s < 3; s++) {
            const double *u = target + 3 * s, *v = target + 3 * ((s + 1) % 3);
            double sx = v[0] - u[0], sy = v[1] - u[1], sz = v[2] - u[2];
            double px = point[0] - u[0], py = point[1] - u[1], pz = point[2] - u[2];
            double inward = (sy * pz - sz * py) * normal[0] + (sz * px - sx * pz) * normal[1] +
                            (sx * py - sy * px) * normal[2];
            if (!(inward > tol * sqrt(sx * sx + sy * sy + sz * sz))) {
                inside = 0;
                break;
            }
        }
        if (inside)
            return 1;
    }
    return 0;
}

/* Do triangles ``a`` and ``b`` of ``tri`` (F, 3, 3) cut through each other? Neighbours
 * (a shared vertex) touch, never cross; a triangle wholly on one side of the other's
 * plane cannot cut it (most pairs). */
static int triangles_cross(const double *tri, const int64_t *faces, const double *normals,
                           double tol, int64_t a, int64_t b)
{
    for (int k = 0; k < 3; k++)
        for (int m = 0; m < 3; m++)
            if (faces[3 * a + k] == faces[3 * b + m])
                return 0;
    const double *ta = tri + 9 * a, *tb = tri + 9 * b;
    double da[3], db[3];
    for (int k = 0; k < 3; k++) {
        db[k] = plane_at(tb + 3 * k, ta, normals + 3 * a);
        da[k] = plane_at(ta + 3 * k, tb, normals + 3 * b);
    }
    if (!(straddles(da, tol) && straddles(db, tol)))
        return 0;
    return edges_pierce(tb, db, ta, normals + 3 * a, tol) ||
           edges_pierce(ta, da, tb, normals + 3 * b, tol);
}

/* A growing list of index pairs. */
typedef struct {
    int64_t *pairs;
    npy_intp count, room;
} PairList;

static int pair_add(PairList *l, int64_t p, int64_t q)
{
    if (l->count == l->room) {
        int64_t *grown = PyMem_RawRealloc(l->pairs, 4 * l->room * sizeof(int64_t));
        if (!grown)
            return 0;
        l->pairs = grown, l->room *= 2;
    }
    l->pairs[2 * l->count] = p, l->pairs[2 * l->count + 1] = q;
    l->count++;
    return 1;
}

/* traverse(node_lo, node_hi (2 leaves - 1, 3), lo, hi (leaves * leaf_size, 3), order (N,),
 * n, leaf_size, narrow, tri (F, 3, 3), faces (F, 3), normals (F, 3), tol) -> (K, 2) int64: the overlapping box
 * pairs (original indices), or with ``narrow`` the crossing triangle pairs among them as
 * (min, max). */
KERNEL(traverse)
{
    CP_NARGS(12);
    IN_F64(0, node_lo, 2);
    IN_F64(1, node_hi, 2);
    IN_F64(2, lo, 2);
    IN_F64(3, hi, 2);
    IN_I64(4, order, 1);
    IN_LONG(5, n);
    IN_LONG(6, leaf_size);
    IN_FLAG(7, narrow);
    IN_F64(8, tri, 3);
    IN_I64(9, faces, 2);
    IN_F64(10, normals, 2);
    IN_DOUBLE(11, tol);
    int64_t leaves = tree_leaf_count(node_lo.shape[0]);
    if (leaves < 1 || leaf_size < 1 || n > lo.shape[0] || n > order.shape[0] || hi.shape[0] != lo.shape[0]) {
        PyErr_SetString(PyExc_ValueError, "traverse: shapes differ");
        return NULL;
    }
    PairList found = {PyMem_RawMalloc(2 * 1024 * sizeof(int64_t)), 0, 1024};
    if (!found.pairs)
        return PyErr_NoMemory();
    const double *nlo = F64(node_lo), *nhi = F64(node_hi), *blo = F64(lo), *bhi = F64(hi);
    const double *t = F64(tri), *nm = F64(normals);
    const int64_t *o = I64(order), *fc = I64(faces);
    int ok = 1;
    Py_BEGIN_ALLOW_THREADS
    int64_t stack[256][3];
    stack[0][0] = 0, stack[0][1] = 0, stack[0][2] = leaves;  /* node a, node b, span */
    int top = 1;
    while (top && ok) {
        top--;
        int64_t a = stack[top][0], b = stack[top][1], span = stack[top][2];
        if (a != b && !boxes_overlap(nlo, nhi, a, nlo, nhi, b))
            continue;
        if (span > 1) {
            for (int64_t ca = 2 * a + 1; ca <= 2 * a + 2; ca++)
                for (int64_t cb = cp_imax(ca, 2 * b + 1); cb <= 2 * b + 2; cb++) {
                    stack[top][0] = ca, stack[top][1] = cb, stack[top][2] = span / 2;
                    top++;
                }
            continue;
        }
        int64_t first = tree_first_item(a, 1, leaves, leaf_size);
        int64_t second = tree_first_item(b, 1, leaves, leaf_size);
        int64_t first_stop = cp_imin(n, first + leaf_size);
        int64_t second_stop = cp_imin(n, second + leaf_size);
        for (int64_t i = first; i < first_stop && ok; i++)
            for (int64_t j = a == b ? i + 1 : second; j < second_stop; j++) {
                if (!boxes_overlap(blo, bhi, i, blo, bhi, j))
                    continue;
                int64_t p = o[i], q = o[j];
                if (narrow) {
                    if (!triangles_cross(t, fc, nm, tol, p, q))
                        continue;
                    int64_t low = cp_imin(p, q);
                    q = cp_imax(p, q), p = low;
                }
                if (!pair_add(&found, p, q)) {
                    ok = 0;
                    break;
                }
            }
    }
    Py_END_ALLOW_THREADS
    PyArrayObject *out = NULL;
    if (ok) {
        npy_intp dims[2] = {found.count, 2};
        out = cp_new(2, dims, NPY_INT64);
        if (out)
            memcpy(PyArray_DATA(out), found.pairs, 2 * found.count * sizeof(int64_t));
    } else
        PyErr_NoMemory();
    PyMem_RawFree(found.pairs);
    return (PyObject *)out;
}

static PyMethodDef intersect_methods[] = {
    ENTRY(traverse, "(node_lo, node_hi, lo, hi, order, n, leaf_size, narrow, tri, faces, normals,"
                    " tol) "
                    "-> (K, 2) overlapping box pairs, or crossing triangle pairs"),
    END_ENTRIES};
