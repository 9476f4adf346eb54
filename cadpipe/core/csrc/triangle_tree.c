/* Building a mesh's triangle tree (cadpipe.collision.chain_mesh.TriangleTree): the leaf
 * order, median splits of the triangles' centroids, and each inner node's oriented box. */
#include "native.h"

/* numpy's order of floats: NaN after every number */
static inline int float_less(double a, double b) { return a < b || (b != b && a == a); }

/* Sort ``idx[0:n]`` by ``keys[idx]``, stably (a merge sort through ``work``, n entries):
 * what np.argsort(kind="mergesort") gives. */
static void stable_argsort(const double *keys, int64_t *idx, int64_t *work, int64_t n)
{
    for (int64_t width = 1; width < n; width *= 2) {
        for (int64_t lo = 0; lo < n; lo += 2 * width) {
            int64_t mid = cp_imin(lo + width, n), hi = cp_imin(lo + 2 * width, n);
            int64_t i = lo, j = mid, k = lo;
            while (i < mid && j < hi)
                work[k++] = float_less(keys[idx[j]], keys[idx[i]]) ? idx[j++] : idx[i++];
            while (i < mid)
                work[k++] = idx[i++];
            while (j < hi)
                work[k++] = idx[j++];
        }
        memcpy(idx, work, sizeof(int64_t) * n);
    }
}

static inline void swap_at(double *keys, int64_t *order, int64_t x, int64_t y)
{
    double k = keys[x];
    keys[x] = keys[y], keys[y] = k;
    int64_t o = order[x];
    order[x] = order[y], order[y] = o;
}

/* Hoare's partition of ``keys[low:high + 1]`` (and ``order`` alike) about the median of its
 * first, middle and last key; returns the pivot's place. */
static int64_t partition(double *keys, int64_t *order, int64_t low, int64_t high)
{
    int64_t mid = (low + high) >> 1;
    if (keys[mid] < keys[low])
        swap_at(keys, order, mid, low);
    if (keys[high] < keys[mid])
        swap_at(keys, order, high, mid);
    if (keys[mid] < keys[low])
        swap_at(keys, order, mid, low);
    double pivot = keys[mid];
    swap_at(keys, order, high, mid);
    int64_t i = low, j = high - 1;
    for (;;) {
        while (i < high && keys[i] < pivot)
            i++;
        while (j >= low && pivot < keys[j])
            j--;
        if (i >= j)
            break;
        swap_at(keys, order, i, j);
        i++;
        j--;
    }
    swap_at(keys, order, i, high);
    return i;
}

/* Reorder ``keys[low:high + 1]`` and ``order`` alike so that no key before ``k`` is larger
 * than one from ``k`` on: quickselect (median of three), or a stable sort once it has taken
 * more rounds than a balanced one would (a bounded worst case for any input). ``work``
 * holds 3 * (high - low + 1) entries. Returns 0, or -2 when there is no memory. */
static int split_at(double *keys, int64_t *order, int64_t low, int64_t high, int64_t k)
{
    int64_t rounds = 0, limit = 2 * (int64_t)log2((double)(high - low + 1)) + 4;
    while (low < high) {
        if (rounds > limit) {
            int64_t n = high - low + 1;
            int64_t *part = malloc(sizeof(int64_t) * 3 * n);
            double *sorted = malloc(sizeof(double) * n);
            if (!part || !sorted) {
                free(part);
                free(sorted);
                return -2;
            }
            for (int64_t q = 0; q < n; q++)
                part[q] = q;
            stable_argsort(keys + low, part, part + n, n);
            int64_t *moved = part + 2 * n;
            for (int64_t q = 0; q < n; q++)
                sorted[q] = keys[low + part[q]], moved[q] = order[low + part[q]];
            memcpy(keys + low, sorted, sizeof(double) * n);
            memcpy(order + low, moved, sizeof(int64_t) * n);
            free(part);
            free(sorted);
            return 0;
        }
        rounds++;
        int64_t i = partition(keys, order, low, high);
        if (i == k)
            return 0;
        if (i < k)
            low = i + 1;
        else
            high = i - 1;
    }
    return 0;
}

/* ``order`` (F,): the leaf order of triangles with centroids ``centroid`` (F, 3) in a perfect
 * tree of ``depth``: level by level, each node's triangles split at its second child's first
 * leaf along the longest extent of their centroids (a quickselect per node: O(F) a level).
 * Returns 0, or -2 when there is no memory. */
static int median_order(const double *centroid, int64_t count, int64_t depth, int64_t *order)
{
    double *keys = malloc(sizeof(double) * (count > 0 ? count : 1));
    if (!keys)
        return -2;
    for (int64_t k = 0; k < count; k++)
        order[k] = k;
    for (int64_t d = 0; d < depth; d++) {
        int64_t slots = (int64_t)1 << (depth - d);
        for (int64_t a = 0; a < count; a += slots) {
            int64_t b = cp_imin(a + slots, count), m = a + slots / 2;
            if (m >= b)
                continue;
            double lo[3], hi[3];
            for (int r = 0; r < 3; r++)
                lo[r] = hi[r] = centroid[3 * order[a] + r];
            for (int64_t k = a + 1; k < b; k++)
                for (int r = 0; r < 3; r++) {
                    lo[r] = cp_min(lo[r], centroid[3 * order[k] + r]);
                    hi[r] = cp_max(hi[r], centroid[3 * order[k] + r]);
                }
            int axis = 0;                 /* np.argmax: the first largest, NaN first */
            double extent[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
            for (int r = 1; r < 3 && extent[axis] == extent[axis]; r++)
                if (extent[r] > extent[axis] || extent[r] != extent[r])
                    axis = r;
            for (int64_t k = a; k < b; k++)
                keys[k] = centroid[3 * order[k] + axis];
            if (split_at(keys, order, a, b - 1, m)) {
                free(keys);
                return -2;
            }
        }
    }
    free(keys);
    return 0;
}

/* The eigenvectors of the symmetric 3x3 ``a`` as the rows of ``axes``, by ascending
 * eigenvalue: cyclic Jacobi rotations until the off-diagonal part is negligible. The
 * product of rotations is orthonormal to rounding, all an oriented box needs (its extents
 * are measured along the axes). */
static void principal_axes(const double a_in[3][3], double axes[3][3])
{
    double a[3][3], v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    memcpy(a, a_in, sizeof a);
    static const int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
    for (int sweep = 0; sweep < 64; sweep++) {
        double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        double diagonal = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if (!(off > 1e-36 * diagonal))      /* also all zero, and NaN */
            break;
        for (int k = 0; k < 3; k++) {
            int p = pairs[k][0], q = pairs[k][1];
            if (a[p][q] == 0.0)
                continue;
            /* the rotation in the (p, q) plane that zeroes a[p][q]: t = tan, the smaller */
            double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            double t = (theta >= 0.0 ? 1.0 : -1.0) / (fabs(theta) + hypot(theta, 1.0));
            double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
            for (int r = 0; r < 3; r++) {          /* a = a J */
                double x = a[r][p], y = a[r][q];
                a[r][p] = c * x - s * y, a[r][q] = s * x + c * y;
            }
            for (int r = 0; r < 3; r++) {          /* a = J^T a */
                double x = a[p][r], y = a[q][r];
                a[p][r] = c * x - s * y, a[q][r] = s * x + c * y;
            }
            a[p][q] = a[q][p] = 0.0;
            for (int r = 0; r < 3; r++) {          /* v = v J */
                double x = v[r][p], y = v[r][q];
                v[r][p] = c * x - s * y, v[r][q] = s * x + c * y;
            }
        }
    }
    int rank[3] = {0, 1, 2};                   /* by ascending eigenvalue, stably */
    for (int i = 1; i < 3; i++)
        for (int j = i; j > 0 && a[rank[j]][rank[j]] < a[rank[j - 1]][rank[j - 1]]; j--) {
            int swap = rank[j];
            rank[j] = rank[j - 1], rank[j - 1] = swap;
        }
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            axes[r][c] = v[c][rank[r]];
}

/* ``frames`` (inner, 15), zeroed: per node above the leaves of the tree of ``depth`` (heap
 * order) over the leaves ``triangles`` (L, 9) (the first ``count`` hold a triangle), an
 * oriented box holding the corners of its triangles as centre, axes (3, 3, as rows) and
 * half extents, the axes the principal axes of those corners (the least spread first),
 * each half extent widened by ``slack``; zeros for a node without a triangle. Returns 0, or
 * -2 when there is no memory. */
static int triangle_frames(const double *triangles, int64_t count, int64_t depth, double slack,
                           double *frames)
{
    int64_t inner = ((int64_t)1 << depth) - 1;
    if (inner == 0)
        return 0;
    /* moments about the corners' middle (no cancellation far from the origin) */
    double low[3] = {INFINITY, INFINITY, INFINITY}, high[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int64_t k = 0; k < count; k++)
        for (int r = 0; r < 9; r++) {
            low[r % 3] = cp_min(low[r % 3], triangles[9 * k + r]);
            high[r % 3] = cp_max(high[r % 3], triangles[9 * k + r]);
        }
    double origin[3];
    for (int r = 0; r < 3; r++)
        origin[r] = 0.5 * (low[r] + high[r]);
    /* per node: corner count, sums (3), second moments (xx, xy, xz, yy, yz, zz) */
    double *moments = calloc((size_t)inner * 10, sizeof(double));
    if (!moments)
        return -2;
    for (int64_t k = 0; k < count; k++) {
        double *row = moments + 10 * ((inner + k - 1) / 2);
        for (int c = 0; c < 3; c++) {
            const double *corner = triangles + 9 * k + 3 * c;
            double x = corner[0] - origin[0], y = corner[1] - origin[1], z = corner[2] - origin[2];
            double v[10] = {1.0, x, y, z, x * x, x * y, x * z, y * y, y * z, z * z};
            for (int q = 0; q < 10; q++)
                row[q] += v[q];
        }
    }
    for (int64_t node = inner - 1; node > 0; node--)
        for (int q = 0; q < 10; q++)
            moments[10 * ((node - 1) / 2) + q] += moments[10 * node + q];
    for (int64_t node = 0; node < inner; node++) {
        const double *row = moments + 10 * node;
        double n = row[0];
        if (n == 0.0)
            continue;
        double mean[3] = {row[1] / n, row[2] / n, row[3] / n}, spread[3][3], axes[3][3];
        int q = 4;
        for (int i = 0; i < 3; i++)
            for (int j = i; j < 3; j++) {
                spread[i][j] = spread[j][i] = row[q] / n - mean[i] * mean[j];
                q++;
            }
        principal_axes((const double(*)[3])spread, axes);
        int level = 0;
        while (((int64_t)2 << level) - 1 <= node)
            level++;
        int64_t width = (int64_t)1 << (depth - level);
        int64_t first = (node - (((int64_t)1 << level) - 1)) * width;
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (int64_t k = first; k < cp_imin(first + width, count); k++)
            for (int c = 0; c < 3; c++) {
                const double *corner = triangles + 9 * k + 3 * c;
                double x = corner[0] - origin[0], y = corner[1] - origin[1],
                       z = corner[2] - origin[2];
                for (int r = 0; r < 3; r++) {
                    double v = axes[r][0] * x + axes[r][1] * y + axes[r][2] * z;
                    lo[r] = cp_min(lo[r], v), hi[r] = cp_max(hi[r], v);
                }
            }
        double *f = frames + 15 * node;
        for (int c = 0; c < 3; c++) {
            f[c] = origin[c];
            for (int r = 0; r < 3; r++) {
                f[c] += axes[r][c] * 0.5 * (lo[r] + hi[r]);
                f[3 + 3 * r + c] = axes[r][c];
            }
            f[12 + c] = 0.5 * (hi[c] - lo[c]) + slack;
        }
    }
    free(moments);
    return 0;
}

/* median_order(centroid (F, 3), depth, order (F,)) */
KERNEL(median_order)
{
    CP_NARGS(3);
    IN_F64(0, centroid, 2);
    IN_LONG(1, depth);
    OUT_I64(2, order, 1);
    if (centroid.shape[1] != 3 || order.shape[0] != centroid.shape[0] || depth < 0 ||
        depth > TREE_DEPTH_MAX || ((int64_t)1 << depth) < centroid.shape[0]) {
        PyErr_SetString(PyExc_ValueError, "median_order: shapes differ");
        return NULL;
    }
    int status;
    Py_BEGIN_ALLOW_THREADS
    status = median_order(F64(centroid), centroid.shape[0], depth, I64(order));
    Py_END_ALLOW_THREADS
    if (status)
        return PyErr_NoMemory();
    Py_RETURN_NONE;
}

/* triangle_frames(triangles (2**depth, 9), count, depth, slack, frames (2**depth - 1, 15)) */
KERNEL(triangle_frames)
{
    CP_NARGS(5);
    IN_F64(0, triangles, 2);
    IN_LONG(1, count);
    IN_LONG(2, depth);
    IN_DOUBLE(3, slack);
    OUT_F64(4, frames, 2);
    if (depth < 0 || depth > TREE_DEPTH_MAX || triangles.shape[1] != 9 ||
        triangles.shape[0] != (npy_intp)1 << depth || count < 0 || count > triangles.shape[0] ||
        frames.shape[1] != 15 || frames.shape[0] != triangles.shape[0] - 1) {
        PyErr_SetString(PyExc_ValueError, "triangle_frames: shapes differ");
        return NULL;
    }
    int status;
    Py_BEGIN_ALLOW_THREADS
    memset(F64(frames), 0, sizeof(double) * frames.size);
    status = triangle_frames(F64(triangles), count, depth, slack, F64(frames));
    Py_END_ALLOW_THREADS
    if (status)
        return PyErr_NoMemory();
    Py_RETURN_NONE;
}

static PyMethodDef triangle_tree_methods[] = {
    ENTRY(median_order, "(centroid (F, 3), depth, order (F,)): the triangle tree's leaf order"),
    ENTRY(triangle_frames, "(triangles (L, 9), count, depth, slack, frames (L - 1, 15)): the"
                           " inner nodes' oriented boxes"),
    END_ENTRIES};
