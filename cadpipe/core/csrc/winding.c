/* Generalized winding numbers from the box tree (cadpipe.geometry.winding explains both
 * ways): the signed count of a ray's crossings for a closed surface, the solid angles
 * summed down the tree (node caps for nodes whose box does not hold the point) for any
 * triangle set; and the facts they need, whether the surface is closed and every node's
 * boundary. Triangles and faces come in the tree's order (tree.h's layout). */
#include "native.h"
#include "tree.h"

/* most triangles a leaf of a winding tree holds (cadpipe.core.tree.LEAF is 4) */
#define MAX_LEAF 16

/* Sort ``keys`` (n) ascending as unsigned numbers, through ``scratch`` (n): least
 * significant digit first, 11 bits a pass, only over the bits that differ. */
static void sort_keys(uint64_t *keys, npy_intp n, uint64_t *scratch)
{
    uint64_t differ = 0;
    for (npy_intp i = 1; i < n; i++)
        differ |= keys[i] ^ keys[0];
    int bits = 0;
    while (bits < 64 && (differ >> bits))
        bits++;
    uint64_t *from = keys, *to = scratch;
    for (int shift = 0; shift < bits; shift += 11) {
        npy_intp count[2049] = {0};
        for (npy_intp i = 0; i < n; i++)
            count[((from[i] >> shift) & 2047) + 1]++;
        for (int d = 0; d < 2048; d++)
            count[d + 1] += count[d];
        for (npy_intp i = 0; i < n; i++)
            to[count[(from[i] >> shift) & 2047]++] = from[i];
        uint64_t *swap = from;
        from = to, to = swap;
    }
    if (from != keys)
        memcpy(keys, from, n * sizeof(uint64_t));
}

/* The key ``low * V + high`` of a vertex pair, wrapping as int64 arithmetic does. */
static inline uint64_t edge_key(int64_t low, int64_t high, int64_t vertex_count)
{
    return (uint64_t)low * (uint64_t)vertex_count + (uint64_t)high;
}

/* Is every edge of ``faces`` (F, 3) walked as often one way as the other? The edges
 * walked low to high and those walked high to low (a vertex pair as ``low * V + high``)
 * must be the same multiset. -1 when out of memory. */
static int faces_closed(const int64_t *faces, npy_intp count, int64_t vertex_count)
{
    uint64_t *keys = PyMem_RawMalloc((9 * count + 1) * sizeof(uint64_t));
    if (!keys)
        return -1;
    uint64_t *up = keys, *down = keys + 3 * count, *scratch = keys + 6 * count;
    npy_intp ups = 0, downs = 0;
    for (npy_intp f = 0; f < count; f++)
        for (int c = 0; c < 3; c++) {
            int64_t a = faces[3 * f + c], b = faces[3 * f + (c + 1) % 3];
            if (a < b)
                up[ups++] = edge_key(a, b, vertex_count);
            else if (a > b)
                down[downs++] = edge_key(b, a, vertex_count);
        }
    int closed = ups == downs;
    if (closed) {
        sort_keys(up, ups, scratch);
        sort_keys(down, downs, scratch);
        closed = memcmp(up, down, ups * sizeof(uint64_t)) == 0;
    }
    PyMem_RawFree(keys);
    return closed;
}

/* closed(faces (F, 3), vertex_count) -> bool */
KERNEL(closed)
{
    CP_NARGS(2);
    IN_I64(0, faces, 2);
    IN_LONG(1, vertex_count);
    int closed;
    Py_BEGIN_ALLOW_THREADS
    closed = faces_closed(I64(faces), faces.shape[0], vertex_count);
    Py_END_ALLOW_THREADS
    if (closed < 0)
        return PyErr_NoMemory();
    return PyBool_FromLong(closed);
}

/* Python's ``a // b``, and ``a % b`` into ``*rem``, for b > 0 with ``inv`` = 1 / b: for
 * 0 <= a < 2**50 (every key of a mesh of up to 33 million vertices) the quotient from a
 * product of doubles, off by at most one and corrected, since a 64-bit division was a
 * seventh of caps' time; else by the integer division. */
static inline int64_t divmod_by(int64_t a, int64_t b, double inv, int64_t *rem)
{
    if (a >= 0 && a < ((int64_t)1 << 50)) {
        int64_t q = (int64_t)((double)a * inv), r = a - q * b;
        while (r < 0)
            q--, r += b;
        while (r >= b)
            q++, r -= b;
        *rem = r;
        return q;
    }
    *rem = cp_mod(a, b);
    return cp_floordiv(a, b);
}

/* ``key``, ``times`` grown to ``size`` entries, the first ``used`` kept; 0 when out of
 * memory (the old blocks kept). */
static int grown(int64_t **key, int64_t **times, npy_intp size)
{
    int64_t *k = PyMem_RawRealloc(*key, size * sizeof(int64_t));
    if (!k)
        return 0;
    *key = k;
    int64_t *t = PyMem_RawRealloc(*times, size * sizeof(int64_t));
    if (!t)
        return 0;
    *times = t;
    return 1;
}

/* caps(faces (F, 3) in tree order, leaves, leaf_size, vertex_count) -> (first, count
 * (2 leaves - 1,),
 * edges (E, 2), times (E,)): node k's boundary edges are rows first[k]:first[k] + count[k]
 * of edges, each (low, high) vertex pair walked ``times`` more often from low to high
 * than back. Leaves from their triangles, each node by merging its children's (both
 * sorted by edge). */
KERNEL(caps)
{
    CP_NARGS(4);
    IN_I64(0, faces, 2);
    IN_LONG(1, leaves);
    IN_LONG(2, leaf_size);
    IN_LONG(3, vertex_count);
    npy_intp nf = faces.shape[0];
    if (leaves < 1 || leaf_size < 1 || leaf_size > MAX_LEAF || nf > leaves * leaf_size ||
        (nf && vertex_count < 1)) {
        PyErr_SetString(PyExc_ValueError, "caps: faces, leaves and vertices differ");
        return NULL;
    }
    npy_intp nodes = 2 * leaves - 1, size = 16 + 3 * nf;
    npy_intp dims[1] = {nodes};
    PyArrayObject *first_arr = cp_new(1, dims, NPY_INT64), *count_arr = cp_new(1, dims, NPY_INT64);
    int64_t *key = PyMem_RawMalloc(size * sizeof(int64_t));
    int64_t *times = PyMem_RawMalloc(size * sizeof(int64_t));
    int ok = first_arr && count_arr && key && times;
    int64_t used = 0;
    const int64_t *fc = I64(faces);
    if (ok) {
        int64_t *first = PyArray_DATA(first_arr), *count = PyArray_DATA(count_arr);
        memset(first, 0, nodes * sizeof(int64_t));
        memset(count, 0, nodes * sizeof(int64_t));
        Py_BEGIN_ALLOW_THREADS
        int64_t leaf_key[3 * MAX_LEAF], leaf_times[3 * MAX_LEAF];
        for (int64_t leaf = 0; leaf < leaves; leaf++) {
            int64_t node = leaves - 1 + leaf;
            int m = 0;
            for (int64_t f = leaf * leaf_size; f < cp_imin(nf, (leaf + 1) * leaf_size); f++)
                for (int c = 0; c < 3; c++) {
                    int64_t a = fc[3 * f + c], b = fc[3 * f + (c + 1) % 3];
                    if (a != b) {
                        leaf_key[m] = (int64_t)edge_key(cp_imin(a, b), cp_imax(a, b),
                                                        vertex_count);
                        leaf_times[m] = a < b ? 1 : -1;
                        m++;
                    }
                }
            for (int r = 1; r < m; r++) {        /* insertion sort: a leaf's few edges */
                int64_t k = leaf_key[r], w = leaf_times[r];
                int q = r;
                while (q && leaf_key[q - 1] > k) {
                    leaf_key[q] = leaf_key[q - 1], leaf_times[q] = leaf_times[q - 1];
                    q--;
                }
                leaf_key[q] = k, leaf_times[q] = w;
            }
            first[node] = used;
            for (int r = 0; r < m; r++) {
                if (used > first[node] && key[used - 1] == leaf_key[r]) {
                    times[used - 1] += leaf_times[r];
                    if (times[used - 1] == 0)
                        used--;
                } else {
                    key[used] = leaf_key[r], times[used] = leaf_times[r];
                    used++;
                }
            }
            count[node] = used - first[node];
        }
        for (int64_t node = leaves - 2; node >= 0 && ok; node--) {
            int64_t c0 = 2 * node + 1, c1 = 2 * node + 2;
            npy_intp need = used + count[c0] + count[c1];
            if (need > size) {
                size = 2 * need;
                ok = grown(&key, &times, size);
                if (!ok)
                    break;
            }
            first[node] = used;
            int64_t i = first[c0], i_end = first[c0] + count[c0];
            int64_t j = first[c1], j_end = first[c1] + count[c1];
            while (i < i_end || j < j_end) {
                if (j == j_end || (i < i_end && key[i] < key[j])) {
                    key[used] = key[i], times[used] = times[i];
                    i++;
                } else if (i == i_end || key[j] < key[i]) {
                    key[used] = key[j], times[used] = times[j];
                    j++;
                } else {
                    key[used] = key[i], times[used] = times[i] + times[j];
                    i++, j++;
                }
                if (times[used] != 0)
                    used++;
            }
            count[node] = used - first[node];
        }
        Py_END_ALLOW_THREADS
    }
    PyArrayObject *edges_arr = NULL, *times_arr = NULL;
    if (ok) {
        npy_intp edims[2] = {used, 2}, tdims[1] = {used};
        edges_arr = cp_new(2, edims, NPY_INT64), times_arr = cp_new(1, tdims, NPY_INT64);
        ok = edges_arr && times_arr;
    }
    if (ok) {
        int64_t *e = PyArray_DATA(edges_arr);
        double inv = 1.0 / (double)vertex_count;
        for (int64_t k = 0; k < used; k++)
            e[2 * k] = divmod_by(key[k], vertex_count, inv, &e[2 * k + 1]);
        memcpy(PyArray_DATA(times_arr), times, used * sizeof(int64_t));
    }
    PyMem_RawFree(key);
    PyMem_RawFree(times);
    if (!ok) {
        Py_XDECREF(first_arr);
        Py_XDECREF(count_arr);
        Py_XDECREF(edges_arr);
        Py_XDECREF(times_arr);
        return PyErr_Occurred() ? NULL : PyErr_NoMemory();
    }
    return Py_BuildValue("NNNN", first_arr, count_arr, edges_arr, times_arr);
}

/* Half the signed solid angle of the triangle a, b, c seen from ``p`` (Van Oosterom
 * and Strackee, 1983). */
static inline double half_angle(const double *p, double ax, double ay, double az, double bx,
                                double by, double bz, double cx, double cy, double cz)
{
    ax -= p[0], ay -= p[1], az -= p[2];
    bx -= p[0], by -= p[1], bz -= p[2];
    cx -= p[0], cy -= p[1], cz -= p[2];
    double la = sqrt(ax * ax + ay * ay + az * az);
    double lb = sqrt(bx * bx + by * by + bz * bz);
    double lc = sqrt(cx * cx + cy * cy + cz * cz);
    double det = ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx);
    double dots = la * lb * lc + (ax * bx + ay * by + az * bz) * lc +
                  (bx * cx + by * cy + bz * cz) * la + (cx * ax + cy * ay + cz * az) * lb;
    return atan2(det, dots);
}

static inline double triangle_half_angle(const double *p, const double *t)
{
    return half_angle(p, t[0], t[1], t[2], t[3], t[4], t[5], t[6], t[7], t[8]);
}

/* The tree and caps the solid-angle walk reads. */
typedef struct {
    const double *node_lo, *node_hi, *tri, *vertices;
    const int64_t *cap_first, *cap_count, *cap_edges, *cap_times;
    int64_t leaves, leaf_size, n;
} WindingTree;

/* The winding number at ``p``: the tree walked from the root, a node whose box does not
 * hold p summed through its cap when that is smaller than its triangles, leaves and the
 * rest triangle by triangle. */
static double winding_at(const WindingTree *w, const double *p)
{
    int64_t stack[128][2];
    double total = 0.0;
    stack[0][0] = 0, stack[0][1] = w->leaves;              /* node, leaves under it */
    int top = 1;
    while (top) {
        top--;
        int64_t node = stack[top][0], span = stack[top][1];
        int64_t start = tree_first_item(node, span, w->leaves, w->leaf_size);
        int64_t stop = cp_imin(w->n, start + span * w->leaf_size);
        if (stop <= start)
            continue;
        const double *lo = w->node_lo + 3 * node, *hi = w->node_hi + 3 * node;
        int outside = 0;
        for (int axis = 0; axis < 3; axis++)
            outside = outside || p[axis] < lo[axis] || p[axis] > hi[axis];
        if (outside && w->cap_count[node] < stop - start) {
            double cx = 0.5 * (lo[0] + hi[0]), cy = 0.5 * (lo[1] + hi[1]);
            double cz = 0.5 * (lo[2] + hi[2]);
            for (int64_t e = w->cap_first[node]; e < w->cap_first[node] + w->cap_count[node];
                 e++) {
                const double *a = w->vertices + 3 * w->cap_edges[2 * e];
                const double *b = w->vertices + 3 * w->cap_edges[2 * e + 1];
                total += w->cap_times[e] *
                         half_angle(p, cx, cy, cz, a[0], a[1], a[2], b[0], b[1], b[2]);
            }
        } else if (outside || span == 1) {
            for (int64_t t = start; t < stop; t++)
                total += triangle_half_angle(p, w->tri + 9 * t);
        } else {
            for (int64_t child = 2 * node + 1; child <= 2 * node + 2; child++) {
                stack[top][0] = child, stack[top][1] = span / 2;
                top++;
            }
        }
    }
    return total / (2 * 3.141592653589793);
}

/* winding(points (P, 3), node_lo, node_hi, tri (F, 3, 3), cap_first, cap_count, cap_edges,
 * cap_times, vertices (V, 3), leaf_size, out (P,)) */
KERNEL(winding)
{
    CP_NARGS(11);
    IN_F64(0, points, 2);
    IN_F64(1, node_lo, 2);
    IN_F64(2, node_hi, 2);
    IN_F64(3, tri, 3);
    IN_I64(4, cap_first, 1);
    IN_I64(5, cap_count, 1);
    IN_I64(6, cap_edges, 2);
    IN_I64(7, cap_times, 1);
    IN_F64(8, vertices, 2);
    IN_LONG(9, leaf_size);
    OUT_F64(10, out, 1);
    int64_t leaves = tree_leaf_count(node_lo.shape[0]);
    if (out.shape[0] != points.shape[0] || cap_first.shape[0] != node_lo.shape[0] ||
        cap_count.shape[0] != node_lo.shape[0]) {
        PyErr_SetString(PyExc_ValueError, "winding: shapes differ");
        return NULL;
    }
    WindingTree w = {F64(node_lo), F64(node_hi), F64(tri), F64(vertices), I64(cap_first),
                     I64(cap_count), I64(cap_edges), I64(cap_times), leaves, leaf_size,
                     tri.shape[0]};
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < points.shape[0]; i++)
        F64(out)[i] = winding_at(&w, F64(points) + 3 * i);
    Py_END_ALLOW_THREADS
    Py_RETURN_NONE;
}

/* Does the ray from ``p`` along ``sign`` times axis ``k`` cross triangle ``c`` (9)? +1
 * leaving along its normal, -1 entering, 0 not, 2 too close to call. In the plane across
 * the axis the ray is a point; it crosses when it lies on the same side of the three
 * edges. An edge's side is the 2D cross product of its ends seen from the ray, computed
 * the same (negated) for both faces of an edge, so a ray through the edge is counted
 * once; within ``grain`` times the edge's size of it the call is left unsure. */
static inline int ray_crossing(const double *c, const double *p, int k, double sign,
                               double grain)
{
    int u = (k + 1) % 3, v = (k + 2) % 3;
    double au = c[u] - p[u], av = c[v] - p[v];
    double bu = c[3 + u] - p[u], bv = c[3 + v] - p[v];
    double cu = c[6 + u] - p[u], cv = c[6 + v] - p[v];
    double e_ab = au * bv - av * bu, e_bc = bu * cv - bv * cu, e_ca = cu * av - cv * au;
    double la = fabs(au) + fabs(av), lb = fabs(bu) + fabs(bv), lc = fabs(cu) + fabs(cv);
    double t_ab = 1e3 * grain * (la + lb), t_bc = 1e3 * grain * (lb + lc);
    double t_ca = 1e3 * grain * (lc + la);
    if ((e_ab > t_ab || e_bc > t_bc || e_ca > t_ca) &&
        (e_ab < -t_ab || e_bc < -t_bc || e_ca < -t_ca))
        return 0;                                       /* clearly beside it */
    if (fabs(e_ab) <= t_ab || fabs(e_bc) <= t_bc || fabs(e_ca) <= t_ca)
        return 2;                                       /* along an edge or vertex */
    double d = e_ab + e_bc + e_ca;                      /* twice the projected area */
    /* where it crosses: corners weighted by the opposite edges' sides (all of one sign) */
    double x = (e_bc * c[k] + e_ca * c[3 + k] + e_ab * c[6 + k]) / d - p[k];
    double extent = cp_max(cp_max(c[k], c[3 + k]), c[6 + k]) -
                    cp_min(cp_min(c[k], c[3 + k]), c[6 + k]);
    if (fabs(x) <= 1e3 * grain + 1e-6 * extent)
        return 2;                                       /* the point is on it */
    if (sign * x < 0)
        return 0;                                       /* behind the point */
    return sign * d > 0 ? 1 : -1;
}

/* The signed count of the triangles ``tri`` the ray from ``p`` crosses, along the axis
 * towards the nearest side of the root box; 0 outside the box. ``*unsure`` is set (and
 * the count left) where a crossing is too close to call; it is read first, as set. */
static double crossings_at(const double *node_lo, const double *node_hi, const double *tri,
                           int64_t leaves, int64_t leaf_size, int64_t n, double grain,
                           const double *p, npy_bool *unsure)
{
    int k = 0;
    double sign = 1.0, room = INFINITY;
    for (int axis = 0; axis < 3; axis++) {
        if (p[axis] < node_lo[axis] || p[axis] > node_hi[axis])
            room = -INFINITY;                           /* outside the box: 0 */
        if (node_hi[axis] - p[axis] < room)
            k = axis, sign = 1.0, room = node_hi[axis] - p[axis];
        if (p[axis] - node_lo[axis] < room)
            k = axis, sign = -1.0, room = p[axis] - node_lo[axis];
    }
    if (room < 0)
        return 0.0;
    int u = (k + 1) % 3, v = (k + 2) % 3;
    double count = 0.0;
    int64_t stack[128][2];
    stack[0][0] = 0, stack[0][1] = leaves;
    int top = 1;
    while (top && !*unsure) {
        top--;
        int64_t node = stack[top][0], span = stack[top][1];
        const double *lo = node_lo + 3 * node, *hi = node_hi + 3 * node;
        if (!(lo[u] <= p[u] && p[u] <= hi[u] && lo[v] <= p[v] && p[v] <= hi[v] &&
              sign * (sign > 0 ? hi[k] : lo[k]) >= sign * p[k] - 1e3 * grain))
            continue;
        if (span > 1) {
            for (int64_t child = 2 * node + 1; child <= 2 * node + 2; child++) {
                stack[top][0] = child, stack[top][1] = span / 2;
                top++;
            }
            continue;
        }
        int64_t start = tree_first_item(node, 1, leaves, leaf_size);
        for (int64_t t = start; t < cp_imin(n, start + leaf_size); t++) {
            int crossed = ray_crossing(tri + 9 * t, p, k, sign, grain);
            if (crossed == 2) {
                *unsure = 1;
                break;
            }
            count += crossed;
        }
    }
    return count;
}

/* crossings(points (P, 3), node_lo, node_hi, tri (F, 3, 3), leaf_size, out (P,), unsure
 * (P,) bool):
 * a closed surface's winding number at each point by a ray; where the ray passes within
 * rounding of an edge or vertex, or a crossing is within rounding of the point, unsure
 * is set instead (the answer is then left to the solid angles). */
KERNEL(crossings)
{
    CP_NARGS(7);
    IN_F64(0, points, 2);
    IN_F64(1, node_lo, 2);
    IN_F64(2, node_hi, 2);
    IN_F64(3, tri, 3);
    IN_LONG(4, leaf_size);
    OUT_F64(5, out, 1);
    OUT_BOOL(6, unsure, 1);
    int64_t leaves = tree_leaf_count(node_lo.shape[0]);
    if (out.shape[0] != points.shape[0] || unsure.shape[0] != points.shape[0] || leaves < 1) {
        PyErr_SetString(PyExc_ValueError, "crossings: shapes differ");
        return NULL;
    }
    const double *lo = F64(node_lo), *hi = F64(node_hi);
    double scale = 0.0;
    for (int axis = 0; axis < 3; axis++)
        scale = cp_max(cp_max(scale, fabs(lo[axis])), fabs(hi[axis]));
    double grain = 1e-12 * scale;          /* ~1e4 float64 steps at the mesh's coordinates */
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < points.shape[0]; i++)
        F64(out)[i] = crossings_at(lo, hi, F64(tri), leaves, leaf_size, tri.shape[0], grain,
                                   F64(points) + 3 * i, BOOL(unsure) + i);
    Py_END_ALLOW_THREADS
    Py_RETURN_NONE;
}

static PyMethodDef winding_methods[] = {
    ENTRY(closed, "(faces (F, 3), vertex_count) -> is every edge walked as often each way"),
    ENTRY(caps, "(faces (F, 3) in tree order, leaves, leaf_size, vertex_count) -> (first, "
                "count, "
                "edges, times): every node's boundary"),
    ENTRY(winding, "(points, node_lo, node_hi, tri, cap_first, cap_count, cap_edges, "
                   "cap_times, vertices, leaf_size, out): winding numbers by solid angles"),
    ENTRY(crossings, "(points, node_lo, node_hi, tri, leaf_size, out, unsure): a closed "
                     "surface's "
                     "winding numbers by a ray"),
    END_ENTRIES};
