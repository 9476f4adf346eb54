/* Shading normals with a crease angle (cadpipe.io.normals): angle-weighted vertex normals,
 * the crease test, the extra rows of crease vertices, and a pipe's inner rings' normals
 * from their ring neighbours.
 *
 * Normals are float32 (what glTF and USD store); the faces' geometry is float64 where the
 * Python side documents it so. The hot loops run over blocks or component rows of
 * contiguous floats with no branches that the compiler cannot turn into selects, so they
 * vectorize without any reassociation of the arithmetic. The faces passed to every kernel
 * here are those vertex_normals checked first (indices in [0, V)). */
#include "native.h"

#ifndef F32
#define F32(a) ((float *)(a).data)
#endif
#ifndef OUT_F32
#define OUT_F32(i, name, nd) CP_ARR(i, name, NPY_FLOAT32, nd, 1)
#endif

/* The hot loops are compiled for AVX-512 (x86-64-v4) and AVX2 (v3) beside the baseline,
 * and the CPU picks one when the extension is loaded: the same IEEE operations in the same
 * order (no contraction: -ffp-contract=off), in wider vectors, so the same results. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__ELF__)
#define NORMALS_WIDE __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define NORMALS_WIDE
#endif

/* faces per block of vertex_normals (its block arrays stay in L1 cache) */
#define NORMALS_BLOCK 512
/* rings per chunk of inner_ring_normals (its component rows stay in cache) */
#define NORMALS_RINGS 128

/* arctan2(y, x) for y >= 0 to float32 accuracy, without branches (so a loop of them
 * vectorizes): an odd minimax polynomial of arctan on [0, 1] (in powers of t**2, max
 * error 3.8e-8 rad) folded to the octant. The weights need no more, and the library
 * arctangent was most of the normals' cost. */
static inline double shading_angle(double y, double x)
{
    double ax = fabs(x);
    double t = cp_min(y, ax) / cp_max(cp_max(y, ax), 1e-300);
    double z = t * t;
    double a = t * (0.9999993355792427 +
                    z * (-0.3332986078552379 +
                         z * (0.19946565651546788 +
                              z * (-0.139086295105954 +
                                   z * (0.09642197156556104 +
                                        z * (-0.05591232372186997 +
                                             z * (0.02186295538583439 +
                                                  z * -0.004054566441771568)))))));
    /* pi / 2 - a where y > ax, and pi - that where x < 0, as selects of constants: the
     * compiler may not move floating-point arithmetic out from under a condition
     * (-ftrapping-math), and a loop with conditional arithmetic does not vectorize.
     * Exact: 0.0 + 1.0 * a is a (a >= +0), c + -1.0 * a is c - a. */
    int folds = y > ax, turns = x < 0;
    a = (folds ? M_PI / 2 : 0.0) + (folds ? -1.0 : 1.0) * a;
    return (turns ? M_PI : 0.0) + (turns ? -1.0 : 1.0) * a;
}

/* ``v`` where ``keep``, else +0.0, by a mask rather than a branch (see shading_angle). */
static inline double kept_or_zero(int keep, double v)
{
    uint64_t bits;
    memcpy(&bits, &v, sizeof bits);
    bits &= -(uint64_t)(keep != 0);
    memcpy(&v, &bits, sizeof bits);
    return v;
}

/* Add to ``out`` (V, 3) the faces' unit normals weighted by their corner angles and fill
 * ``fn`` (F, 3) with the faces' unit normals (zero if degenerate), a block of faces at a
 * time: gather the corners, then the angles (a vectorized loop), then add. Returns 0, or
 * -1 (the blocks before it summed) at a block holding an index outside [0, nv). */
NORMALS_WIDE static int normals_sum(const double *p, npy_intp nv, const int64_t *fc,
                                    npy_intp nf, float *out, float *fn)
{
    double nx[NORMALS_BLOCK], ny[NORMALS_BLOCK], nz[NORMALS_BLOCK];
    double dot0[NORMALS_BLOCK], dot1[NORMALS_BLOCK], weight0[NORMALS_BLOCK],
        weight1[NORMALS_BLOCK];
    for (npy_intp start = 0; start < nf; start += NORMALS_BLOCK) {
        int count = (int)(nf - start < NORMALS_BLOCK ? nf - start : NORMALS_BLOCK);
        const int64_t *f = fc + 3 * start;
        uint64_t beyond = 0;                 /* the block's indices checked, then in cache */
        for (int c = 0; c < 3 * count; c++)
            beyond |= (uint64_t)f[c] >= (uint64_t)nv;
        if (beyond)
            return -1;
        for (int o = 0; o < count; o++) {
            const double *vi = p + 3 * f[3 * o], *vj = p + 3 * f[3 * o + 1],
                         *vk = p + 3 * f[3 * o + 2];
            double ax = vj[0] - vi[0], ay = vj[1] - vi[1], az = vj[2] - vi[2]; /* 0 -> 1 */
            double cx = vi[0] - vk[0], cy = vi[1] - vk[1], cz = vi[2] - vk[2]; /* 2 -> 0 */
            double bx = -ax - cx, by = -ay - cy, bz = -az - cz;                /* 1 -> 2 */
            nx[o] = ay * bz - az * by;
            ny[o] = az * bx - ax * bz;
            nz[o] = ax * by - ay * bx;
            dot0[o] = -(ax * cx + ay * cy + az * cz);
            dot1[o] = -(ax * bx + ay * by + az * bz);
        }
        for (int o = 0; o < count; o++) {
            /* every corner's edge cross product is 2 * area long: the angle at a corner is
             * atan2(2 * area, dot of its edges); the three sum to pi */
            double twice_area = sqrt(nx[o] * nx[o] + ny[o] * ny[o] + nz[o] * nz[o]);
            double scale = kept_or_zero(twice_area > 0.0, 1.0 / twice_area); /* degenerate: 0 */
            nx[o] *= scale;
            ny[o] *= scale;
            nz[o] *= scale;
            weight0[o] = shading_angle(twice_area, dot0[o]);
            weight1[o] = shading_angle(twice_area, dot1[o]);
        }
        for (int o = 0; o < count; o++) {
            double w0 = weight0[o], w1 = weight1[o];
            double w2 = M_PI - w0 - w1;
            float *face = fn + 3 * (start + o);
            face[0] = (float)nx[o];
            face[1] = (float)ny[o];
            face[2] = (float)nz[o];
            float *ni = out + 3 * f[3 * o], *nj = out + 3 * f[3 * o + 1],
                  *nk = out + 3 * f[3 * o + 2];
            ni[0] = (float)(ni[0] + nx[o] * w0);
            ni[1] = (float)(ni[1] + ny[o] * w0);
            ni[2] = (float)(ni[2] + nz[o] * w0);
            nj[0] = (float)(nj[0] + nx[o] * w1);
            nj[1] = (float)(nj[1] + ny[o] * w1);
            nj[2] = (float)(nj[2] + nz[o] * w1);
            nk[0] = (float)(nk[0] + nx[o] * w2);
            nk[1] = (float)(nk[1] + ny[o] * w2);
            nk[2] = (float)(nk[2] + nz[o] * w2);
        }
    }
    return 0;
}

/* vertex_normals(vertices (V, 3) float64, faces (F, 3) int64, normals (V, 3) float32,
 * face_normals (F, 3) float32): add to ``normals`` (zeros where they are to be
 * computed) the faces' unit normals weighted by their corner angles (not areas: a
 * vertex normal then does not depend on how the surface around it is cut into
 * triangles), and fill ``face_normals`` with the faces' unit normals (zero if
 * degenerate); see normals_sum. IndexError for a face index outside [0, V). */
KERNEL(vertex_normals)
{
    CP_NARGS(4);
    IN_F64(0, vertices, 2);
    IN_I64(1, faces, 2);
    OUT_F32(2, normals, 2);
    OUT_F32(3, face_normals, 2);
    npy_intp nv = vertices.shape[0], nf = faces.shape[0];
    if (vertices.shape[1] != 3 || faces.shape[1] != 3 || normals.shape[0] != nv ||
        normals.shape[1] != 3 || face_normals.shape[0] != nf || face_normals.shape[1] != 3) {
        PyErr_SetString(PyExc_ValueError, "vertex_normals: vertices (V, 3), faces (F, 3), "
                                          "normals (V, 3), face_normals (F, 3)");
        return NULL;
    }
    int failed;
    Py_BEGIN_ALLOW_THREADS
    failed = normals_sum(F64(vertices), nv, I64(faces), nf, F32(normals), F32(face_normals));
    Py_END_ALLOW_THREADS
    if (failed) {
        PyErr_SetString(PyExc_IndexError, "vertex_normals: a face's vertex index is outside "
                                          "[0, V)");
        return NULL;
    }
    Py_RETURN_NONE;
}

/* unit_rows(normals (V, 3) float32, start, stop): scale rows start:stop to unit length
 * (zero rows stay zero). */
KERNEL(unit_rows)
{
    CP_NARGS(3);
    OUT_F32(0, normals, 2);
    IN_LONG(1, start);
    IN_LONG(2, stop);
    if (normals.shape[1] != 3 || start < 0 || stop > normals.shape[0]) {
        PyErr_SetString(PyExc_ValueError, "unit_rows: normals (V, 3), 0 <= start, stop <= V");
        return NULL;
    }
    float *n = F32(normals);
    Py_BEGIN_ALLOW_THREADS
    for (int64_t v = start; v < stop; v++) {
        float *row = n + 3 * v;
        float length = sqrtf(row[0] * row[0] + row[1] * row[1] + row[2] * row[2]);
        double scale = length > 0.0f ? 1.0 / length : 0.0;
        for (int c = 0; c < 3; c++)
            row[c] = (float)(row[c] * scale);
    }
    Py_END_ALLOW_THREADS
    Py_RETURN_NONE;
}

/* on_crease(face_normals (F, 3) float32, faces (F, 3) int64, normals (V, 3) float32,
 * cos_half, crease (V,) bool): set ``crease`` where some face at the vertex is more than
 * half the angle off its normal (float32 cosine ``cos_half``; a degenerate face, of zero
 * normal, counts as off). */
KERNEL(on_crease)
{
    CP_NARGS(5);
    IN_F32(0, face_normals, 2);
    IN_I64(1, faces, 2);
    IN_F32(2, normals, 2);
    IN_DOUBLE(3, cos_half_arg);
    OUT_BOOL(4, crease, 1);
    if (face_normals.size != faces.size || normals.shape[0] != crease.size) {
        PyErr_SetString(PyExc_ValueError, "on_crease: arrays of unlike sizes");
        return NULL;
    }
    const float *fn = F32(face_normals), *n = F32(normals);
    const int64_t *fc = I64(faces);
    npy_bool *out = BOOL(crease);
    float cos_half = (float)cos_half_arg;
    npy_intp nf = faces.shape[0];
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp f = 0; f < nf; f++) {
        float nx = fn[3 * f], ny = fn[3 * f + 1], nz = fn[3 * f + 2];
        for (int c = 0; c < 3; c++) {
            int64_t v = fc[3 * f + c];
            if (nx * n[3 * v] + ny * n[3 * v + 1] + nz * n[3 * v + 2] < cos_half)
                out[v] = 1;
        }
    }
    Py_END_ALLOW_THREADS
    Py_RETURN_NONE;
}

/* The unit normal of face ``f`` (zero if degenerate). */
static inline void crease_face_normal(const double *p, const int64_t *face, double out[3])
{
    const double *vi = p + 3 * face[0], *vj = p + 3 * face[1], *vk = p + 3 * face[2];
    double ax = vj[0] - vi[0], ay = vj[1] - vi[1], az = vj[2] - vi[2];
    double bx = vk[0] - vj[0], by = vk[1] - vj[1], bz = vk[2] - vj[2];
    double nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
    double twice_area = sqrt(nx * nx + ny * ny + nz * nz);
    if (twice_area > 0) {
        out[0] = nx / twice_area;
        out[1] = ny / twice_area;
        out[2] = nz / twice_area;
    } else
        out[0] = out[1] = out[2] = 0.0;
}

/* The angle of a face at its corner ``k``. */
static inline double crease_corner_angle(const double *p, const int64_t *face, int k)
{
    const double *vi = p + 3 * face[k], *vj = p + 3 * face[(k + 1) % 3],
                 *vm = p + 3 * face[(k + 2) % 3];
    double ux = vj[0] - vi[0], uy = vj[1] - vi[1], uz = vj[2] - vi[2];
    double wx = vm[0] - vi[0], wy = vm[1] - vi[1], wz = vm[2] - vi[2];
    double cx = uy * wz - uz * wy, cy = uz * wx - ux * wz, cz = ux * wy - uy * wx;
    return shading_angle(sqrt(cx * cx + cy * cy + cz * cz), ux * wx + uy * wy + uz * wz);
}

/* Sort ``keys`` (n non-negative int64, all below ``bound``) ascending: least significant
 * digit radix sort, 11 bits a pass, through ``spare`` (n). */
static void crease_sort(int64_t *keys, int64_t *spare, npy_intp n, int64_t bound)
{
    int bits = 0;
    while (bits < 63 && ((int64_t)1 << bits) < bound)
        bits++;
    int64_t *from = keys, *to = spare;
    npy_intp count[2048];
    for (int shift = 0; shift < bits; shift += 11) {
        memset(count, 0, sizeof count);
        for (npy_intp i = 0; i < n; i++)
            count[(from[i] >> shift) & 2047]++;
        npy_intp at = 0;
        for (int d = 0; d < 2048; d++) {
            npy_intp c = count[d];
            count[d] = at;
            at += c;
        }
        for (npy_intp i = 0; i < n; i++)
            to[count[(from[i] >> shift) & 2047]++] = from[i];
        int64_t *t = from;
        from = to;
        to = t;
    }
    if (from != keys)
        memcpy(keys, from, sizeof(int64_t) * (size_t)n);
}

/* The extra rows of crease vertices (see crease_rows); -1 when out of memory. Fills
 * ``*extra`` (E, 3) float32 rows and ``*moved_corner``, ``*moved_row`` (K,) and
 * ``*extra_vertex`` (E,), allocated here (freed by the caller), and updates the crease
 * vertices' rows of ``normals``. */
static int crease_rows_impl(const double *p, npy_intp nv, const int64_t *fc, npy_intp nf,
                            float *normals, const npy_bool *on_crease, double cos_full,
                            float **extra_out, int64_t **corner_out, int64_t **row_out,
                            int64_t **vertex_out, npy_intp *n_extra, npy_intp *n_moved)
{
    /* the corners at crease vertices, grouped by vertex in corner order (key: vertex *
     * 3F + corner) */
    npy_intp m = 3 * nf, count = 0;
    for (npy_intp c = 0; c < m; c++)
        count += on_crease[fc[c]] != 0;
    size_t slots = (size_t)(count > 0 ? count : 1);
    int64_t *keys = malloc(sizeof(int64_t) * slots);
    int64_t *spare = malloc(sizeof(int64_t) * slots);
    if (!keys || !spare) {
        free(keys);
        free(spare);
        return -1;
    }
    count = 0;
    for (npy_intp c = 0; c < m; c++)
        if (on_crease[fc[c]])
            keys[count++] = fc[c] * (int64_t)m + c;
    crease_sort(keys, spare, count, (int64_t)nv * (int64_t)m);
    free(spare);
    int64_t *vertex_of = malloc(sizeof(int64_t) * slots), *corner = keys;
    double *face_normal = malloc(sizeof(double) * 3 * slots);
    double *weight = malloc(sizeof(double) * slots);
    float *summed = calloc(3 * slots, sizeof(float));
    int64_t *row = malloc(sizeof(int64_t) * slots), *extra_of = malloc(sizeof(int64_t) * slots);
    if (!vertex_of || !face_normal || !weight || !summed || !row || !extra_of) {
        free(keys);
        free(vertex_of);
        free(face_normal);
        free(weight);
        free(summed);
        free(row);
        free(extra_of);
        return -1;
    }
    for (npy_intp c = 0; c < count; c++) {
        vertex_of[c] = keys[c] / m;
        corner[c] = keys[c] - vertex_of[c] * m;          /* in place of its key */
        int64_t f = corner[c] / 3;
        int k = (int)(corner[c] % 3);
        crease_face_normal(p, fc + 3 * f, face_normal + 3 * c);
        weight[c] = crease_corner_angle(p, fc + 3 * f, k);
        row[c] = -1;
    }
    npy_intp extra = 0;
    for (npy_intp start = 0; start < count;) {
        npy_intp stop = start;
        while (stop < count && vertex_of[stop] == vertex_of[start])
            stop++;
        int64_t v = vertex_of[start];
        float *nv_row = normals + 3 * v;
        int slot_taken = 0;              /* by a degenerate face's corner or the first sum */
        for (npy_intp c = start; c < stop; c++) {
            const double *fc_n = face_normal + 3 * c;
            double sx = 0.0, sy = 0.0, sz = 0.0;
            for (npy_intp d = start; d < stop; d++) {
                const double *fd = face_normal + 3 * d;
                if (fc_n[0] * fd[0] + fc_n[1] * fd[1] + fc_n[2] * fd[2] >= cos_full) {
                    sx += fd[0] * weight[d];
                    sy += fd[1] * weight[d];
                    sz += fd[2] * weight[d];
                }
            }
            double length = sqrt(sx * sx + sy * sy + sz * sz);
            if (length > 0.0) {
                summed[3 * c] = (float)(sx / length);
                summed[3 * c + 1] = (float)(sy / length);
                summed[3 * c + 2] = (float)(sz / length);
            } else {
                row[c] = v;
                slot_taken = 1;
            }
        }
        for (npy_intp c = start; c < stop; c++) {
            if (row[c] != -1)
                continue;
            const float *s = summed + 3 * c;
            for (npy_intp d = start; d < c; d++) { /* an equal normal met before (not 0) */
                const float *e = summed + 3 * d;
                if (e[0] == s[0] && e[1] == s[1] && e[2] == s[2]) {
                    row[c] = row[d];
                    break;
                }
            }
            if (row[c] != -1)
                continue;
            if (!slot_taken) {                          /* the first takes the vertex's row */
                row[c] = v;
                slot_taken = 1;
                nv_row[0] = s[0];
                nv_row[1] = s[1];
                nv_row[2] = s[2];
            } else if (s[0] == nv_row[0] && s[1] == nv_row[1] && s[2] == nv_row[2]) {
                row[c] = v;             /* the vertex normal a degenerate face's corner keeps */
            } else {
                row[c] = nv + extra;
                extra_of[extra++] = c;
            }
        }
        start = stop;
    }
    /* the results, packed into the arrays that are no longer needed */
    npy_intp moved = 0;
    for (npy_intp c = 0; c < count; c++)
        if (row[c] >= nv) {
            corner[moved] = corner[c];
            row[moved] = row[c];
            moved++;
        }
    float *rows3 = (float *)face_normal;                 /* 3E floats fit in 3 * count doubles */
    for (npy_intp e = 0; e < extra; e++) {
        memcpy(rows3 + 3 * e, summed + 3 * extra_of[e], 3 * sizeof(float));
        vertex_of[e] = vertex_of[extra_of[e]];
    }
    free(weight);
    free(summed);
    free(extra_of);
    *extra_out = rows3;
    *corner_out = corner;
    *row_out = row;
    *vertex_out = vertex_of;
    *n_extra = extra;
    *n_moved = moved;
    return 0;
}

/* A new 1-d or 2-d (n, 3) array holding a copy of ``data`` (n rows). */
static PyArrayObject *crease_array(const void *data, npy_intp n, int columns, int type,
                                   size_t item)
{
    npy_intp dims[2] = {n, 3};
    PyArrayObject *a = cp_new(columns ? 2 : 1, dims, type);
    if (a && n)
        memcpy(PyArray_DATA(a), data, item * (size_t)n * (columns ? 3 : 1));
    return a;
}

/* crease_rows(vertices (V, 3) float64, faces (F, 3) int64, normals (V, 3) float32,
 * on_crease (V,) bool, cos_full) -> (extra (E, 3) float32, corners (K,), rows (K,),
 * vertex (E,) int64): the normals of the corners at crease vertices. Each corner there
 * takes the unit angle-weighted sum of the normals of the faces at its vertex within the
 * full angle of its own face's (cosine ``cos_full``). Per vertex, the first distinct sum
 * takes the vertex's own row of ``normals`` (updated here) and each further one a new
 * row, V + e (``extra[e]``, a row of vertex ``vertex[e]``); a corner of a degenerate
 * face (whose sum is zero) keeps the vertex normal, and then every sum takes a new row.
 * ``corners`` (flat indices into faces) are the corners that take a new row, ``rows``
 * their rows. */
KERNEL(crease_rows)
{
    CP_NARGS(5);
    IN_F64(0, vertices, 2);
    IN_I64(1, faces, 2);
    OUT_F32(2, normals, 2);
    IN_BOOL(3, on_crease, 1);
    IN_DOUBLE(4, cos_full);
    npy_intp nv = vertices.shape[0];
    if (vertices.shape[1] != 3 || faces.shape[1] != 3 || normals.shape[0] != nv ||
        normals.shape[1] != 3 || on_crease.size != nv) {
        PyErr_SetString(PyExc_ValueError, "crease_rows: vertices (V, 3), faces (F, 3), "
                                          "normals (V, 3), on_crease (V,)");
        return NULL;
    }
    float *extra;
    int64_t *corner, *row, *vertex;
    npy_intp n_extra, n_moved;
    int failed;
    Py_BEGIN_ALLOW_THREADS
    failed = crease_rows_impl(F64(vertices), nv, I64(faces), faces.shape[0], F32(normals),
                              BOOL(on_crease), cos_full, &extra, &corner, &row, &vertex,
                              &n_extra, &n_moved);
    Py_END_ALLOW_THREADS
    if (failed)
        return PyErr_NoMemory();
    PyArrayObject *a = crease_array(extra, n_extra, 1, NPY_FLOAT32, sizeof(float));
    PyArrayObject *b = crease_array(corner, n_moved, 0, NPY_INT64, sizeof(int64_t));
    PyArrayObject *c = crease_array(row, n_moved, 0, NPY_INT64, sizeof(int64_t));
    PyArrayObject *d = crease_array(vertex, n_extra, 0, NPY_INT64, sizeof(int64_t));
    free(extra);
    free(corner);
    free(row);
    free(vertex);
    if (!a || !b || !c || !d) {
        Py_XDECREF(a);
        Py_XDECREF(b);
        Py_XDECREF(c);
        Py_XDECREF(d);
        return NULL;
    }
    return Py_BuildValue("NNNN", a, b, c, d);
}

/* -- a pipe's inner rings ---------------------------------------------------------
 * A chunk of rings at a time is copied into component rows, float32 about the chunk's
 * first vertex (its edges keep 24 bits), each ring padded with its last vertex before it
 * and its first after it: a vertex's neighbours are then the same positions of shifted
 * rows, with no wrap to handle, so every loop runs over whole rows and vectorizes. The
 * pads' own results are dropped. */

/* Copy ``rings`` rings of ``sides`` vertices from row ``base`` of ``p`` into padded
 * component rows (the ring's last vertex, the ring, its first), about the first vertex. */
static void ring_padded_rows(const double *p, int64_t base, int64_t sides, int64_t rings,
                             float *x, float *y, float *z)
{
    double ox = p[3 * base], oy = p[3 * base + 1], oz = p[3 * base + 2];
    int64_t w = sides + 2;
    for (int64_t q = 0; q < rings; q++) {
        const double *ring = p + 3 * (base + q * sides);
        int64_t r = q * w;
        for (int64_t k = 0; k < sides; k++) {
            x[r + 1 + k] = (float)(ring[3 * k] - ox);
            y[r + 1 + k] = (float)(ring[3 * k + 1] - oy);
            z[r + 1 + k] = (float)(ring[3 * k + 2] - oz);
        }
        x[r] = x[r + sides];
        y[r] = y[r + sides];
        z[r] = z[r + sides];
        x[r + w - 1] = x[r + 1];
        y[r + w - 1] = y[r + 1];
        z[r + w - 1] = z[r + 1];
    }
}

/* e[:m]: the unit edges from points a to b (inf or NaN for a zero one). */
NORMALS_WIDE static void ring_unit_edges(const float *ax, const float *ay, const float *az,
                            const float *bx, const float *by, const float *bz,
                            float *restrict ex, float *restrict ey, float *restrict ez,
                            int64_t m)
{
    for (int64_t o = 0; o < m; o++) {
        float dx = bx[o] - ax[o], dy = by[o] - ay[o], dz = bz[o] - az[o];
        float scale = 1.0f / sqrtf(dx * dx + dy * dy + dz * dz);
        ex[o] = dx * scale;
        ey[o] = dy * scale;
        ez[o] = dz * scale;
    }
}

/* Unit normals n[:m] of points with ring neighbours after and before them, a and b, and
 * unit edges along the tube to the next ring, u, and from the ring before, d: the chord
 * around the ring crossed with the sum of the two (unit, so unequal segments do not tilt
 * it); inf or NaN where degenerate. */
NORMALS_WIDE static void ring_normals(const float *ax, const float *ay, const float *az, const float *bx,
                         const float *by, const float *bz, const float *ux, const float *uy,
                         const float *uz, const float *dx, const float *dy, const float *dz,
                         float *restrict nx, float *restrict ny, float *restrict nz,
                         int64_t m)
{
    for (int64_t o = 0; o < m; o++) {
        float cx = ax[o] - bx[o], cy = ay[o] - by[o], cz = az[o] - bz[o];  /* around */
        float wx = ux[o] + dx[o], wy = uy[o] + dy[o], wz = uz[o] + dz[o];  /* along */
        float mx = cy * wz - cz * wy, my = cz * wx - cx * wz, mz = cx * wy - cy * wx;
        float scale = 1.0f / sqrtf(mx * mx + my * my + mz * mz);
        nx[o] = mx * scale;
        ny[o] = my * scale;
        nz[o] = mz * scale;
    }
}

/* How many corners of triangle i, j, k have a normal m more than the spread off the
 * triangle's: f . m < cos |f|, compared as squares with no root (``cos2``: the cosine
 * squared). */
static inline int64_t ring_triangle_off(float ix, float iy, float iz, float jx, float jy,
                                        float jz, float kx, float ky, float kz, float mix,
                                        float miy, float miz, float mjx, float mjy, float mjz,
                                        float mkx, float mky, float mkz, float cos2)
{
    float ax = jx - ix, ay = jy - iy, az = jz - iz;
    float bx = kx - ix, by = ky - iy, bz = kz - iz;
    float fx = ay * bz - az * by, fy = az * bx - ax * bz, fz = ax * by - ay * bx;
    float bound = cos2 * (fx * fx + fy * fy + fz * fz);
    float di = fx * mix + fy * miy + fz * miz;
    float dj = fx * mjx + fy * mjy + fz * mjz;
    float dk = fx * mkx + fy * mky + fz * mkz;
    return (int64_t)(di * fabsf(di) < bound) + (int64_t)(dj * fabsf(dj) < bound) +
           (int64_t)(dk * fabsf(dk) < bound);
}

/* How many corners of the first ``bands`` bands' triangles are more than the spread off
 * their normals. Band q lies between point rows q + 1 and q + 2 (normal rows q and
 * q + 1); its quad at a has the triangles (a, b, c) and (b, d, c), b next in the row, c
 * and d in the next one. One loop over all the bands' positions, so that it vectorizes
 * (a ring's few sides would not): the quad at a padded row's first position repeats its
 * last real one, and ``seam`` (0 at a row's last position, 1 elsewhere) drops the one
 * that spans two rows. */
NORMALS_WIDE static int64_t ring_bands_off(const float *x, const float *y, const float *z, const float *nx,
                              const float *ny, const float *nz, const int32_t *seam,
                              int64_t sides, int64_t bands, float cos2)
{
    int64_t w = sides + 2, m = bands * w, off = 0;
    const float *ax = x + w, *ay = y + w, *az = z + w;
    const float *bx = x + w + 1, *by = y + w + 1, *bz = z + w + 1;
    const float *cx = x + 2 * w, *cy = y + 2 * w, *cz = z + 2 * w;
    const float *dx = x + 2 * w + 1, *dy = y + 2 * w + 1, *dz = z + 2 * w + 1;
    const float *max_ = nx, *may = ny, *maz = nz;
    const float *mbx = nx + 1, *mby = ny + 1, *mbz = nz + 1;
    const float *mcx = nx + w, *mcy = ny + w, *mcz = nz + w;
    const float *mdx = nx + w + 1, *mdy = ny + w + 1, *mdz = nz + w + 1;
    for (int64_t o = 0; o < m; o++)
        off += seam[o] * (ring_triangle_off(ax[o], ay[o], az[o], bx[o], by[o], bz[o], cx[o],
                                            cy[o], cz[o], max_[o], may[o], maz[o], mbx[o],
                                            mby[o], mbz[o], mcx[o], mcy[o], mcz[o], cos2) +
                          ring_triangle_off(bx[o], by[o], bz[o], dx[o], dy[o], dz[o], cx[o],
                                            cy[o], cz[o], mbx[o], mby[o], mbz[o], mdx[o],
                                            mdy[o], mdz[o], mcx[o], mcy[o], mcz[o], cos2));
    return off;
}

/* How many of normals [:m] are not finite (of a zero edge or chord). */
NORMALS_WIDE static int64_t ring_degenerate(const float *nx, const float *ny, int64_t m)
{
    int64_t bad = 0;
    for (int64_t o = 0; o < m; o++)
        bad += !(fabsf(nx[o]) + fabsf(ny[o]) < 2.0f);
    return bad;
}

/* Set ``normals`` of the inner rings of ``runs`` (R, 4: first vertex, ring count, sides,
 * first face) from their ring neighbours and mark them in ``inner``; returns how many
 * tests failed (a degenerate normal, a corner of a face between inner rings more than
 * the spread off its normal), or -1 when out of memory. */
static int64_t ring_pass(const double *p, const int64_t *runs, npy_intp nruns, float *normals,
                         npy_bool *inner, float cos2)
{
    int64_t off = 0;
    for (npy_intp r = 0; r < nruns; r++) {
        int64_t first = runs[4 * r], count = runs[4 * r + 1], sides = runs[4 * r + 2];
        int64_t w = sides + 2;                           /* a padded ring */
        int64_t size = (NORMALS_RINGS + 3) * w;
        float *rows = malloc(sizeof(float) * 9 * (size_t)size);
        int32_t *seam = malloc(sizeof(int32_t) * (size_t)size);
        int64_t *position = malloc(sizeof(int64_t) * (size_t)(NORMALS_RINGS * sides));
        if (!rows || !seam || !position) {
            free(rows);
            free(seam);
            free(position);
            return -1;
        }
        float *x = rows, *y = x + size, *z = y + size, *ex = z + size, *ey = ex + size,
              *ez = ey + size, *nx = ez + size, *ny = nx + size, *nz = ny + size;
        /* the band test reads one normal past those written, at a position ``seam``
         * drops: zeros rather than whatever the memory held */
        memset(nx, 0, sizeof(float) * 3 * (size_t)size);
        for (int64_t i = 0; i < size; i++)
            seam[i] = i % w != w - 1;
        for (int64_t i = 0; i < NORMALS_RINGS * sides; i++)  /* of each vertex in the rows */
            position[i] = i / sides * w + i % sides + 1;
        for (int64_t j0 = 1; j0 < count - 1; j0 += NORMALS_RINGS) {
            int64_t j1 = cp_imin(j0 + NORMALS_RINGS, count - 1); /* rings j0..j1-1 written */
            int64_t last = cp_imin(j1, count - 2);   /* normals of j0..last (one more tested) */
            int64_t rings = last - j0 + 3;           /* points: rings j0-1..last+1 */
            int64_t base = first + (j0 - 1) * sides;
            ring_padded_rows(p, base, sides, rings, x, y, z);
            /* unit edges from each point to the next ring's; then the normals of the rings
             * between the first and last row (normal row q: point row q + 1) */
            ring_unit_edges(x, y, z, x + w, y + w, z + w, ex, ey, ez, (rings - 1) * w);
            ring_normals(x + w + 1, y + w + 1, z + w + 1, x + w - 1, y + w - 1, z + w - 1,
                         ex + w, ey + w, ez + w, ex, ey, ez, nx, ny, nz, (rings - 2) * w);
            for (int c = 0; c < 3; c++) {             /* the pads' normals: their vertices' */
                float *n = c == 0 ? nx : (c == 1 ? ny : nz);
                for (int64_t q = 0; q < rings - 2; q++) {
                    n[q * w] = n[q * w + sides];
                    n[q * w + w - 1] = n[q * w + 1];
                }
            }
            off += ring_bands_off(x, y, z, nx, ny, nz, seam, sides, last - j0, cos2);
            off += ring_degenerate(nx, ny, (j1 - j0) * w);
            int64_t start = first + j0 * sides, stop = first + j1 * sides;
            float *out = normals + 3 * start;
            for (int64_t i = 0; i < stop - start; i++) {
                /* a gather from cache and a write in order, faster than the scatter */
                int64_t o = position[i];
                out[3 * i] = nx[o];
                out[3 * i + 1] = ny[o];
                out[3 * i + 2] = nz[o];
            }
            memset(inner + start, 1, (size_t)(stop - start));
        }
        free(rows);
        free(seam);
        free(position);
    }
    return off;
}

/* inner_ring_normals(vertices (V, 3) float64, runs (R, 4) int64, normals (V, 3) float32,
 * inner (V,) bool, cos_spread) -> bool: set ``normals`` of the inner rings of ``runs``
 * (those with three rings or more) from their ring neighbours (see ring_pass), mark
 * them in ``inner``; False where one is degenerate or a face between inner rings is more
 * than the spread (cosine ``cos_spread``) off a corner's normal. */
KERNEL(inner_ring_normals)
{
    CP_NARGS(5);
    IN_F64(0, vertices, 2);
    IN_I64(1, runs, 2);
    OUT_F32(2, normals, 2);
    OUT_BOOL(3, inner, 1);
    IN_DOUBLE(4, cos_spread);
    npy_intp nv = vertices.shape[0];
    int valid = vertices.shape[1] == 3 && runs.shape[1] == 4 && normals.shape[0] == nv &&
                normals.shape[1] == 3 && inner.size == nv;
    const int64_t *run = I64(runs);
    for (npy_intp r = 0; valid && r < runs.shape[0]; r++) {
        int64_t first = run[4 * r], count = run[4 * r + 1], sides = run[4 * r + 2];
        valid = first >= 0 && count >= 3 && sides >= 1 && sides < (1 << 24) &&
                count <= (nv - first) / sides;
    }
    if (!valid) {
        PyErr_SetString(PyExc_ValueError, "inner_ring_normals: vertices (V, 3), runs (R, 4) "
                                          "of 3 rings or more within the vertices, normals "
                                          "(V, 3), inner (V,)");
        return NULL;
    }
    float cos2 = (float)(cos_spread * cos_spread);
    int64_t off;
    Py_BEGIN_ALLOW_THREADS
    off = ring_pass(F64(vertices), run, runs.shape[0], F32(normals), BOOL(inner), cos2);
    Py_END_ALLOW_THREADS
    if (off < 0)
        return PyErr_NoMemory();
    return PyBool_FromLong(off == 0);
}

/* inner_faces_within(face_normals (F, 3) float32, faces (F, 3) int64, normals (V, 3)
 * float32, inner (V,) bool, cos_spread, other (F,) bool) -> bool: False where a face at an
 * inner ring vertex is more than the spread off its normal (float32 cosine
 * ``cos_spread``), or is ``other`` (not in a run's bands: its vertex normal would miss
 * it). */
KERNEL(inner_faces_within)
{
    CP_NARGS(6);
    IN_F32(0, face_normals, 2);
    IN_I64(1, faces, 2);
    IN_F32(2, normals, 2);
    IN_BOOL(3, inner, 1);
    IN_DOUBLE(4, cos_spread_arg);
    IN_BOOL(5, other, 1);
    if (face_normals.size != faces.size || other.size != faces.shape[0] ||
        normals.shape[0] != inner.size) {
        PyErr_SetString(PyExc_ValueError, "inner_faces_within: arrays of unlike sizes");
        return NULL;
    }
    const float *fn = F32(face_normals), *n = F32(normals);
    const int64_t *fc = I64(faces);
    const npy_bool *in = BOOL(inner), *oth = BOOL(other);
    float cos_spread = (float)cos_spread_arg;
    npy_intp nf = faces.shape[0];
    int within = 1;
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp f = 0; f < nf && within; f++)
        for (int c = 0; c < 3; c++) {
            int64_t v = fc[3 * f + c];
            if (in[v] && (oth[f] || fn[3 * f] * n[3 * v] + fn[3 * f + 1] * n[3 * v + 1] +
                                            fn[3 * f + 2] * n[3 * v + 2] <
                                        cos_spread)) {
                within = 0;
                break;
            }
        }
    Py_END_ALLOW_THREADS
    return PyBool_FromLong(within);
}

/* any_both(a (V,) bool, b (V,) bool, faces (F, 3) int64) -> bool: whether a vertex of
 * ``faces`` is set in both ``a`` and ``b``. */
KERNEL(any_both)
{
    CP_NARGS(3);
    IN_BOOL(0, a, 1);
    IN_BOOL(1, b, 1);
    IN_I64(2, faces, 2);
    if (a.size != b.size) {
        PyErr_SetString(PyExc_ValueError, "any_both: a and b of one size");
        return NULL;
    }
    const npy_bool *pa = BOOL(a), *pb = BOOL(b);
    const int64_t *fc = I64(faces);
    int both = 0;
    for (npy_intp c = 0; c < faces.size; c++)
        if (pa[fc[c]] && pb[fc[c]]) {
            both = 1;
            break;
        }
    return PyBool_FromLong(both);
}

static PyMethodDef normals_methods[] = {
    ENTRY(vertex_normals, "Angle-weighted vertex normals and unit face normals (io.normals)."),
    ENTRY(unit_rows, "Scale rows of float32 normals to unit length."),
    ENTRY(on_crease, "Mark the vertices where a face is more than half the angle off."),
    ENTRY(crease_rows, "The normals of the corners at crease vertices: extra rows."),
    ENTRY(inner_ring_normals, "A pipe's inner rings' normals from their ring neighbours."),
    ENTRY(inner_faces_within, "Whether the faces at inner ring vertices lie within the spread."),
    ENTRY(any_both, "Whether a vertex of the faces is set in both masks."),
    END_ENTRIES};
