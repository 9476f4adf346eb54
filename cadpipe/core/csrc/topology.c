/* Edges and connected pieces of a triangle mesh (cadpipe.geometry.topology): the directed
 * edges grouped by their lower vertex (a counting sort; a group is one vertex's fan) and
 * sorted within each group, which is np.unique's order of the edge keys, at a few bytes
 * an edge; pieces from a union-find over links.
 *
 * The grouped arrays are int32 where their values fit (most of the memory this takes)
 * and int64 past that: ``wide`` says which, one flag per array. */
#include "native.h"

/* a group longer than this is sorted by qsort, shorter ones by insertion */
#define TOPOLOGY_SHORT 32

static inline int64_t index_at(const void *p, int wide, npy_intp i)
{
    return wide ? ((const int64_t *)p)[i] : ((const int32_t *)p)[i];
}

static inline void index_set(void *p, int wide, npy_intp i, int64_t v)
{
    if (wide)
        ((int64_t *)p)[i] = v;
    else
        ((int32_t *)p)[i] = (int32_t)v;
}

/* An int32 or int64 1-d array argument (``wide`` set for int64), writeable when
 * ``write``; 0 with a TypeError set for anything else. */
static int index_array(PyObject *o, int write, Arr *out, int *wide, const char *kernel,
                       int index)
{
    int type = PyArray_Check(o) ? PyArray_TYPE((PyArrayObject *)o) : NPY_INT64;
    *wide = type != NPY_INT32;
    return cp_array(o, *wide ? NPY_INT64 : NPY_INT32, 1, write, out, kernel, index);
}

typedef struct {
    int64_t high, edge;
} HighEdge;

static int by_high(const void *a, const void *b)
{
    int64_t x = ((const HighEdge *)a)->high, y = ((const HighEdge *)b)->high;
    return (x > y) - (x < y);
}

/* Group the directed edges of ``faces`` (F, 3) (edge 3f + c runs from corner c to corner
 * c + 1) by their low end: ``start`` (count + 1) gets the groups' bounds, ``high`` (3F)
 * their high ends, ascending within a group, and ``edge`` (3F, or nothing when not
 * ``track``) the directed edge each came from. Returns -1 when a face holds an index
 * outside [0, count), -2 when out of memory, 0 otherwise. */
static int group_edges(const int64_t *faces, npy_intp nfaces, int64_t count, int64_t *start,
                       void *high, int hwide, void *edge, int ewide, int track)
{
    memset(start, 0, sizeof(int64_t) * (size_t)(count + 1));
    for (npy_intp f = 0; f < nfaces; f++) {
        const int64_t *face = faces + 3 * f;
        for (int c = 0; c < 3; c++)
            if (face[c] < 0 || face[c] >= count)
                return -1;
        for (int c = 0; c < 3; c++)
            start[cp_imin(face[c], face[(c + 1) % 3]) + 1] += 1;
    }
    for (int64_t v = 0; v < count; v++)
        start[v + 1] += start[v];
    int64_t *fill = PyMem_RawMalloc(sizeof(int64_t) * (size_t)(count > 0 ? count : 1));
    if (!fill)
        return -2;
    memcpy(fill, start, sizeof(int64_t) * (size_t)count);
    for (npy_intp f = 0; f < nfaces; f++)
        for (int c = 0; c < 3; c++) {
            int64_t a = faces[3 * f + c], b = faces[3 * f + (c + 1) % 3];
            int64_t low = cp_imin(a, b);
            int64_t slot = fill[low]++;
            index_set(high, hwide, slot, cp_imax(a, b));
            if (track)
                index_set(edge, ewide, slot, 3 * (int64_t)f + c);
        }
    PyMem_RawFree(fill);
    HighEdge *pairs = NULL;
    int64_t room = 0;
    for (int64_t v = 0; v < count; v++) {
        int64_t s = start[v], e = start[v + 1];
        if (e - s > TOPOLOGY_SHORT) {
            if (e - s > room) {
                PyMem_RawFree(pairs);
                room = e - s;
                pairs = PyMem_RawMalloc(sizeof(HighEdge) * (size_t)room);
                if (!pairs)
                    return -2;
            }
            for (int64_t i = s; i < e; i++) {
                pairs[i - s].high = index_at(high, hwide, i);
                pairs[i - s].edge = track ? index_at(edge, ewide, i) : 0;
            }
            qsort(pairs, (size_t)(e - s), sizeof(HighEdge), by_high);
            for (int64_t i = s; i < e; i++) {
                index_set(high, hwide, i, pairs[i - s].high);
                if (track)
                    index_set(edge, ewide, i, pairs[i - s].edge);
            }
        } else {                                /* insertion sort: a vertex's fan is small */
            for (int64_t i = s + 1; i < e; i++) {
                int64_t h = index_at(high, hwide, i), j = i - 1;
                int64_t d = track ? index_at(edge, ewide, i) : 0;
                while (j >= s && index_at(high, hwide, j) > h) {
                    index_set(high, hwide, j + 1, index_at(high, hwide, j));
                    if (track)
                        index_set(edge, ewide, j + 1, index_at(edge, ewide, j));
                    j--;
                }
                index_set(high, hwide, j + 1, h);
                if (track)
                    index_set(edge, ewide, j + 1, d);
            }
        }
    }
    PyMem_RawFree(pairs);
    return 0;
}

/* edge_group(faces (F, 3) int64, count, high (3F,) int32|int64, edge (3F or 0,)
 * int32|int64) -> start (count + 1,) int64: see group_edges (``edge`` empty: not
 * tracked). */
KERNEL(edge_group)
{
    CP_NARGS(4);
    IN_I64(0, faces, 2);
    IN_LONG(1, count);
    Arr high, edge;
    int hwide, ewide;
    if (!index_array(args[2], 1, &high, &hwide, "edge_group", 2) ||
        !index_array(args[3], 1, &edge, &ewide, "edge_group", 3))
        return NULL;
    npy_intp nfaces = faces.shape[0];
    int track = edge.size > 0;
    if (faces.shape[1] != 3 || count < 1 || high.size != 3 * nfaces ||
        (track && edge.size != 3 * nfaces)) {
        PyErr_SetString(PyExc_ValueError, "edge_group: faces (F, 3), count >= 1, high and "
                                          "edge (3F,)");
        return NULL;
    }
    npy_intp dims[1] = {(npy_intp)count + 1};
    PyArrayObject *start = cp_new(1, dims, NPY_INT64);
    if (!start)
        return NULL;
    int failed;
    Py_BEGIN_ALLOW_THREADS
    failed = group_edges(I64(faces), nfaces, count, PyArray_DATA(start), high.data, hwide,
                         edge.data, ewide, track);
    Py_END_ALLOW_THREADS
    if (failed) {
        Py_DECREF(start);
        if (failed == -2)
            return PyErr_NoMemory();
        PyErr_SetString(PyExc_IndexError, "edge_group: a face's vertex index is outside "
                                          "[0, count)");
        return NULL;
    }
    return (PyObject *)start;
}

/* edge_rows(start, high, edge) -> (keys (E,), inverse (3F,), counts (E,)) int64: the
 * undirected edges of the groups (as edge_group made them), each ``low * count +
 * high``, ascending; the row of each directed edge; and how many directed edges each
 * has. */
KERNEL(edge_rows)
{
    CP_NARGS(3);
    IN_I64(0, start, 1);
    Arr high, edge;
    int hwide, ewide;
    if (!index_array(args[1], 0, &high, &hwide, "edge_rows", 1) ||
        !index_array(args[2], 0, &edge, &ewide, "edge_rows", 2))
        return NULL;
    const int64_t *st = I64(start);
    npy_intp count = start.size - 1;
    if (count < 0 || edge.size != high.size || st[count] != high.size) {
        PyErr_SetString(PyExc_ValueError, "edge_rows: start, high and edge of edge_group");
        return NULL;
    }
    npy_intp unique = 0;
    const void *hi = high.data, *ed = edge.data;
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp v = 0; v < count; v++)
        for (int64_t i = st[v]; i < st[v + 1]; i++)
            if (i == st[v] || index_at(hi, hwide, i) != index_at(hi, hwide, i - 1))
                unique++;
    Py_END_ALLOW_THREADS
    npy_intp udims[1] = {unique}, idims[1] = {high.size};
    PyArrayObject *keys_arr = cp_new(1, udims, NPY_INT64);
    PyArrayObject *counts_arr = cp_new(1, udims, NPY_INT64);
    PyArrayObject *inverse_arr = cp_new(1, idims, NPY_INT64);
    if (!keys_arr || !counts_arr || !inverse_arr) {
        Py_XDECREF(keys_arr);
        Py_XDECREF(counts_arr);
        Py_XDECREF(inverse_arr);
        return NULL;
    }
    int64_t *keys = PyArray_DATA(keys_arr), *counts = PyArray_DATA(counts_arr),
            *inverse = PyArray_DATA(inverse_arr);
    Py_BEGIN_ALLOW_THREADS
    memset(counts, 0, sizeof(int64_t) * (size_t)unique);
    int64_t row = -1;
    for (npy_intp v = 0; v < count; v++)
        for (int64_t i = st[v]; i < st[v + 1]; i++) {
            int64_t h = index_at(hi, hwide, i);
            if (i == st[v] || h != index_at(hi, hwide, i - 1)) {
                row++;
                keys[row] = (int64_t)v * (int64_t)count + h;
            }
            counts[row]++;
            inverse[index_at(ed, ewide, i)] = row;
        }
    Py_END_ALLOW_THREADS
    return Py_BuildValue("NNN", keys_arr, inverse_arr, counts_arr);
}

/* edge_pairs(start, high) -> bool: whether every run of equal high ends within a group is
 * two long (every undirected edge has two faces: watertight). */
KERNEL(edge_pairs)
{
    CP_NARGS(2);
    IN_I64(0, start, 1);
    Arr high;
    int hwide;
    if (!index_array(args[1], 0, &high, &hwide, "edge_pairs", 1))
        return NULL;
    const int64_t *st = I64(start);
    npy_intp count = start.size - 1;
    if (count < 0 || st[count] != high.size) {
        PyErr_SetString(PyExc_ValueError, "edge_pairs: start and high of edge_group");
        return NULL;
    }
    int pairs = 1;
    const void *hi = high.data;
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp v = 0; v < count && pairs; v++) {
        int64_t s = st[v], e = st[v + 1];
        for (int64_t i = s; i < e; i += 2) {
            int64_t h = index_at(hi, hwide, i);
            if (i + 1 >= e || index_at(hi, hwide, i + 1) != h ||
                (i + 2 < e && index_at(hi, hwide, i + 2) == h)) {
                pairs = 0;
                break;
            }
        }
    }
    Py_END_ALLOW_THREADS
    return PyBool_FromLong(pairs);
}

/* The root of ``x``'s piece, halving the path to it on the way. */
static inline int64_t piece_root(int64_t *parent, int64_t x)
{
    while (parent[x] != x) {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    return x;
}

/* A 2-d int32 or int64 array of link ends, of any strides (views and broadcasts are read
 * as they are). */
typedef struct {
    const char *data;
    npy_intp rows, cols, row_step, col_step;
    int wide;
} Ends;

static int link_ends(PyObject *o, Ends *out, int index)
{
    if (!PyArray_Check(o) || PyArray_NDIM((PyArrayObject *)o) != 2 ||
        (PyArray_TYPE((PyArrayObject *)o) != NPY_INT64 &&
         PyArray_TYPE((PyArrayObject *)o) != NPY_INT32) ||
        !PyArray_ISALIGNED((PyArrayObject *)o) || !PyArray_ISNOTSWAPPED((PyArrayObject *)o))
        return cp_fail("connected_labels", index, "a 2-d int32 or int64 array", o);
    PyArrayObject *a = (PyArrayObject *)o;
    out->data = PyArray_DATA(a);
    out->rows = PyArray_DIM(a, 0);
    out->cols = PyArray_DIM(a, 1);
    out->row_step = PyArray_STRIDE(a, 0);
    out->col_step = PyArray_STRIDE(a, 1);
    out->wide = PyArray_TYPE(a) == NPY_INT64;
    return 1;
}

static inline int64_t end_at(const Ends *e, npy_intp i, npy_intp j)
{
    const char *p = e->data + i * e->row_step + j * e->col_step;
    return e->wide ? *(const int64_t *)p : *(const int32_t *)p;
}

/* connected_labels(count, a, b) -> (count,) int32: the connected-component label of each
 * of ``count`` nodes linked by every ``a[i, j]`` with ``b[i, j]`` (2-d, one shape),
 * numbered in the order of each piece's lowest node (scipy's connected_components
 * order): a union-find whose roots are each piece's lowest node. */
KERNEL(connected_labels)
{
    CP_NARGS(3);
    IN_LONG(0, count);
    Ends a, b;
    if (!link_ends(args[1], &a, 1) || !link_ends(args[2], &b, 2))
        return NULL;
    if (a.rows != b.rows || a.cols != b.cols || count < 0) {
        PyErr_SetString(PyExc_ValueError, "connected_labels: link ends of one shape");
        return NULL;
    }
    npy_intp dims[1] = {(npy_intp)count};
    PyArrayObject *labels_arr = cp_new(1, dims, NPY_INT32);
    int64_t *parent = PyMem_RawMalloc(sizeof(int64_t) * (size_t)(count > 0 ? count : 1));
    if (!labels_arr || !parent) {
        Py_XDECREF(labels_arr);
        PyMem_RawFree(parent);
        return PyErr_NoMemory();
    }
    int32_t *labels = PyArray_DATA(labels_arr);
    int outside = 0;
    Py_BEGIN_ALLOW_THREADS
    for (int64_t v = 0; v < count; v++)
        parent[v] = v;
    for (npy_intp i = 0; i < a.rows && !outside; i++)
        for (npy_intp j = 0; j < a.cols; j++) {
            int64_t p = end_at(&a, i, j), q = end_at(&b, i, j);
            if (p < 0 || p >= count || q < 0 || q >= count) {
                outside = 1;
                break;
            }
            int64_t x = piece_root(parent, p), y = piece_root(parent, q);
            if (x < y)
                parent[y] = x;
            else if (y < x)
                parent[x] = y;
        }
    int32_t pieces = 0;
    for (int64_t v = 0; v < count && !outside; v++) {
        int64_t root = piece_root(parent, v);
        if (root == v)
            labels[v] = pieces++;
        else
            labels[v] = labels[root];             /* root < v: labelled already */
    }
    Py_END_ALLOW_THREADS
    PyMem_RawFree(parent);
    if (outside) {
        Py_DECREF(labels_arr);
        PyErr_SetString(PyExc_IndexError, "connected_labels: a link's end is outside "
                                          "[0, count)");
        return NULL;
    }
    return (PyObject *)labels_arr;
}

static PyMethodDef topology_methods[] = {
    ENTRY(edge_group, "Directed edges grouped by their low end (geometry.topology)."),
    ENTRY(edge_rows, "The edge table of grouped edges: keys, inverse, counts."),
    ENTRY(edge_pairs, "Whether every undirected edge of grouped edges has two faces."),
    ENTRY(connected_labels, "Connected-component labels of linked nodes (union-find)."),
    END_ENTRIES};
