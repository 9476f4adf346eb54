/* Building the box tree (cadpipe.core.tree.BoxTree, layout in tree.h): the items' boxes
 * in the tree's order, padded with empty ones, and every node's box from the leaves up;
 * and the Morton keys of a Morton order. The walks over it are winding.c's and
 * intersect.c's. */
#include "native.h"
#include "tree.h"

/* Do boxes ``i`` of ``lo``, ``hi`` and ``j`` of ``blo``, ``bhi`` (rows of 3) overlap
 * (touching counts)? */
static inline int boxes_overlap(const double *lo, const double *hi, int64_t i, const double *blo,
                                const double *bhi, int64_t j)
{
    for (int axis = 0; axis < 3; axis++)
        if (lo[3 * i + axis] > bhi[3 * j + axis] || blo[3 * j + axis] > hi[3 * i + axis])
            return 0;
    return 1;
}

/* triangle_boxes(tri (F, 3, 3)) -> (lo, hi) (F, 3): each triangle's box. */
KERNEL(triangle_boxes)
{
    CP_NARGS(1);
    IN_F64(0, tri, 3);
    npy_intp n = tri.shape[0];
    if (tri.shape[1] != 3 || tri.shape[2] != 3) {
        PyErr_SetString(PyExc_ValueError, "triangle_boxes: need (F, 3, 3) triangles");
        return NULL;
    }
    npy_intp dims[2] = {n, 3};
    PyArrayObject *lo = cp_new(2, dims, NPY_FLOAT64), *hi = cp_new(2, dims, NPY_FLOAT64);
    if (!lo || !hi) {
        Py_XDECREF(lo);
        Py_XDECREF(hi);
        return NULL;
    }
    const double *restrict t = F64(tri);
    double *restrict l = PyArray_DATA(lo), *restrict h = PyArray_DATA(hi);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp f = 0; f < n; f++)
        for (int axis = 0; axis < 3; axis++) {
            const double *c = t + 9 * f + axis;
            l[3 * f + axis] = cp_min(cp_min(c[0], c[3]), c[6]);
            h[3 * f + axis] = cp_max(cp_max(c[0], c[3]), c[6]);
        }
    Py_END_ALLOW_THREADS
    return Py_BuildValue("NN", lo, hi);
}

/* tree_build(lo, hi (N, 3), order (N,), leaves, leaf_size) -> (items_lo, items_hi
 * (leaves * leaf_size, 3), node_lo, node_hi (2 leaves - 1, 3)): the boxes in the tree's
 * order padded with empty ones (inf, -inf), and the node boxes in heap order, each leaf
 * the union of its items', each node of its children's. */
KERNEL(tree_build)
{
    CP_NARGS(5);
    IN_F64(0, lo, 2);
    IN_F64(1, hi, 2);
    IN_I64(2, order, 1);
    IN_LONG(3, leaves);
    IN_LONG(4, leaf_size);
    npy_intp n = order.shape[0];
    if (leaves < 1 || leaf_size < 1 || n > leaves * leaf_size || n != lo.shape[0] ||
        lo.shape[0] != hi.shape[0] || (lo.shape[0] && (lo.shape[1] != 3 || hi.shape[1] != 3))) {
        PyErr_SetString(PyExc_ValueError, "tree_build: shapes differ");
        return NULL;
    }
    const int64_t *o = I64(order);
    for (npy_intp i = 0; i < n; i++)
        if (o[i] < 0 || o[i] >= n) {
            PyErr_SetString(PyExc_IndexError, "tree_build: order out of range");
            return NULL;
        }
    npy_intp sizes[2] = {leaves * leaf_size, 3}, nodes[2] = {2 * leaves - 1, 3};
    PyArrayObject *arrays[4] = {cp_new(2, sizes, NPY_FLOAT64), cp_new(2, sizes, NPY_FLOAT64),
                                cp_new(2, nodes, NPY_FLOAT64), cp_new(2, nodes, NPY_FLOAT64)};
    if (!arrays[0] || !arrays[1] || !arrays[2] || !arrays[3]) {
        for (int k = 0; k < 4; k++)
            Py_XDECREF(arrays[k]);
        return NULL;
    }
    double *slo = PyArray_DATA(arrays[0]), *shi = PyArray_DATA(arrays[1]);
    double *nlo = PyArray_DATA(arrays[2]), *nhi = PyArray_DATA(arrays[3]);
    const double *l = F64(lo), *h = F64(hi);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp k = 0; k < sizes[0] * 3; k++)
        slo[k] = INFINITY, shi[k] = -INFINITY;
    for (npy_intp k = 0; k < nodes[0] * 3; k++)
        nlo[k] = INFINITY, nhi[k] = -INFINITY;
    for (npy_intp i = 0; i < n; i++) {
        int64_t leaf = leaves - 1 + i / leaf_size;
        for (int axis = 0; axis < 3; axis++) {
            slo[3 * i + axis] = l[3 * o[i] + axis], shi[3 * i + axis] = h[3 * o[i] + axis];
            nlo[3 * leaf + axis] = cp_min(nlo[3 * leaf + axis], slo[3 * i + axis]);
            nhi[3 * leaf + axis] = cp_max(nhi[3 * leaf + axis], shi[3 * i + axis]);
        }
    }
    for (int64_t node = leaves - 2; node >= 0; node--)
        for (int axis = 0; axis < 3; axis++) {
            nlo[3 * node + axis] = cp_min(nlo[3 * (2 * node + 1) + axis],
                                          nlo[3 * (2 * node + 2) + axis]);
            nhi[3 * node + axis] = cp_max(nhi[3 * (2 * node + 1) + axis],
                                          nhi[3 * (2 * node + 2) + axis]);
        }
    Py_END_ALLOW_THREADS
    return Py_BuildValue("NNNN", arrays[0], arrays[1], arrays[2], arrays[3]);
}

/* The 21 low bits of ``v`` spread to every third bit (bit b to bit 3 b). */
static inline uint64_t spread3(uint64_t v)
{
    v &= 0x1fffff;
    v = (v | v << 32) & 0x1f00000000ffffull;
    v = (v | v << 16) & 0x1f0000ff0000ffull;
    v = (v | v << 8) & 0x100f00f00f00f00full;
    v = (v | v << 4) & 0x10c30c30c30c30c3ull;
    v = (v | v << 2) & 0x1249249249249249ull;
    return v;
}

/* numpy's min and max of a column (NaN if any is NaN). */
static void column_range(const double *c, npy_intp n, int axis, double *low, double *high)
{
    double a = INFINITY, b = -INFINITY;
    for (npy_intp i = 0; i < n; i++) {
        double v = c[3 * i + axis];
        if (isnan(v)) {
            *low = *high = v;
            return;
        }
        a = v < a ? v : a;
        b = v > b ? v : b;
    }
    *low = a, *high = b;
}

/* morton(lo, hi (N, 3)) -> (N,) uint64: the Z-order key of each box's centre, 21 bits per
 * axis over the centres' bounds (bit b of axis a at bit 3 b + a). */
KERNEL(morton)
{
    CP_NARGS(2);
    IN_F64(0, lo, 2);
    IN_F64(1, hi, 2);
    npy_intp n = lo.shape[0];
    if (hi.shape[0] != n || (n && (lo.shape[1] != 3 || hi.shape[1] != 3))) {
        PyErr_SetString(PyExc_ValueError, "morton: need (N, 3) boxes");
        return NULL;
    }
    npy_intp dims[1] = {n};
    PyArrayObject *keys = cp_new(1, dims, NPY_UINT64);
    double *centre = PyMem_RawMalloc((3 * n + 1) * sizeof(double));
    if (!keys || !centre) {
        Py_XDECREF(keys);
        PyMem_RawFree(centre);
        return PyErr_NoMemory();
    }
    uint64_t *key = PyArray_DATA(keys);
    const double *l = F64(lo), *h = F64(hi);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp k = 0; k < 3 * n; k++)
        centre[k] = (l[k] + h[k]) / 2;
    double low[3] = {0.0, 0.0, 0.0}, span[3] = {0.0, 0.0, 0.0};
    for (int axis = 0; axis < 3; axis++) {
        if (n) {
            double high;
            column_range(centre, n, axis, &low[axis], &high);
            span[axis] = high - low[axis];
        }
        if (!(span[axis] > 0))
            span[axis] = 1.0;
    }
    for (npy_intp i = 0; i < n; i++) {
        uint64_t k = 0;
        for (int axis = 0; axis < 3; axis++) {
            /* in [0, 2**21 - 1] for finite centres; NaN (the centre of an infinite box)
             * is the last cell, the same on every CPU */
            double x = (centre[3 * i + axis] - low[axis]) / span[axis] * (double)((1 << 21) - 1);
            uint64_t cell = x >= 0.0 && x < 18446744073709551616.0 ? (uint64_t)x : 0x1fffff;
            k |= spread3(cell) << axis;
        }
        key[i] = k;
    }
    Py_END_ALLOW_THREADS
    PyMem_RawFree(centre);
    return (PyObject *)keys;
}

static PyMethodDef boxtree_methods[] = {
    ENTRY(triangle_boxes, "(tri (F, 3, 3)) -> (lo, hi) (F, 3) boxes of the triangles"),
    ENTRY(tree_build, "(lo, hi, order, leaves, leaf_size) -> (items_lo, items_hi, node_lo,"
                      " node_hi): the box tree's boxes"),
    ENTRY(morton, "(lo, hi (N, 3)) -> (N,) uint64 Morton keys of the box centres"),
    END_ENTRIES};
