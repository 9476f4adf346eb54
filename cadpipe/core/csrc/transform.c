/* 4x4 placements: the checks of a placement matrix, points and poses moved by them.
 *
 * An explicit product, never BLAS: numpy's ``points @ M.T`` on (N, 3) rows goes through
 * BLAS, whose threads spin on a busy machine (0.21 s of a 0.35 s STL write at a load of
 * 2 on 2 cores, against 0.016 s in one thread; docs/performance.md). */
#include "native.h"

enum { NOT_FINITE = 1, NOT_AFFINE = 2, NOT_RIGID = 3, FLAT = 4 };

/* The first failing check of one matrix ``m`` (16, row by row), in as_matrix's order:
 * finite entries; a last row of 0 0 0 1 (as np.allclose); with ``rigid`` that row within
 * 1e-9, R^T R within 1e-6 of the identity and det R > 0; |det R| >= 1e-12. */
static int matrix_problem(const double *m, int rigid, int stage)
{
    static const double last[4] = {0.0, 0.0, 0.0, 1.0};
    if (stage == 0) {
        for (int k = 0; k < 16; k++)
            if (!isfinite(m[k]))
                return NOT_FINITE;
        return 0;
    }
    if (stage == 1) {
        for (int c = 0; c < 4; c++)
            if (fabs(m[12 + c] - last[c]) > 1e-8 + 1e-5 * fabs(last[c]))
                return NOT_AFFINE;
        return 0;
    }
    double det = m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
                 m[2] * (m[4] * m[9] - m[5] * m[8]);
    if (rigid) {
        for (int c = 0; c < 4; c++)
            if (fabs(m[12 + c] - last[c]) > 1e-9)
                return NOT_RIGID;
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) {
                double v = m[i] * m[j] + m[4 + i] * m[4 + j] + m[8 + i] * m[8 + j];
                if (fabs(v - (i == j ? 1.0 : 0.0)) > 1e-6)
                    return NOT_RIGID;
            }
        if (!(det > 0))
            return NOT_RIGID;
    }
    if (fabs(det) < 1e-12)
        return FLAT;
    return 0;
}

/* The first failing check over a stack of ``count`` matrices, each check over all of
 * them before the next (as_matrix reports the first kind of problem). */
static int stack_problem(const double *m, npy_intp count, int rigid)
{
    for (int stage = 0; stage < 3; stage++)
        for (npy_intp k = 0; k < count; k++) {
            int p = matrix_problem(m + 16 * k, rigid, stage);
            if (p)
                return p;
        }
    return 0;
}

KERNEL(matrix_problem)
{
    CP_NARGS(2);
    IN_F64(0, matrices, 3);
    IN_FLAG(1, rigid);
    return PyLong_FromLong(stack_problem(F64(matrices), matrices.shape[0], rigid));
}

/* set_pose(matrix (4, 4), poses (N, 4, 4), versions (N,), i): a rigid ``matrix`` is
 * written into ``poses[i]`` and ``versions[i]`` counts the move (0 returned); any other
 * is refused with its problem code and nothing is written. A pose set per call. */
KERNEL(set_pose)
{
    CP_NARGS(4);
    IN_F64(0, matrix, 2);
    OUT_F64(1, poses, 3);
    OUT_I64(2, versions, 1);
    IN_LONG(3, i);
    int problem = stack_problem(F64(matrix), 1, 1);
    if (!problem) {
        memcpy(F64(poses) + 16 * i, F64(matrix), 16 * sizeof(double));
        I64(versions)[i]++;
    }
    return PyLong_FromLong(problem);
}

/* ``out`` (E, 4, 4) = inv(pose_a) @ pose_b for rigid poses (the inverse is the transposed
 * rotation): each b in its a's frame. */
static void relative_poses(const double *pa, const double *pb, double *out, npy_intp count)
{
    for (npy_intp e = 0; e < count; e++) {
        const double *a = pa + 16 * e, *b = pb + 16 * e;
        double *o = out + 16 * e;
        for (int r = 0; r < 3; r++) {
            for (int c = 0; c < 4; c++) {
                /* row r of inv(a) is column r of a's rotation; its shift is -R^T t */
                double v = a[r] * b[c] + a[4 + r] * b[4 + c] + a[8 + r] * b[8 + c];
                if (c == 3)
                    v -= a[r] * a[3] + a[4 + r] * a[7] + a[8 + r] * a[11];
                o[4 * r + c] = v;
            }
        }
        o[12] = 0.0, o[13] = 0.0, o[14] = 0.0, o[15] = 1.0;
    }
}

KERNEL(relative_poses)
{
    CP_NARGS(3);
    IN_F64(0, pose_a, 3);
    IN_F64(1, pose_b, 3);
    OUT_F64(2, out, 3);
    relative_poses(F64(pose_a), F64(pose_b), F64(out), pose_a.shape[0]);
    Py_RETURN_NONE;
}

/* ``out`` (n, 3) = C-ordered ``points`` (n, 3) moved by the 4x4 ``m`` (16, row by row): what
 * a walk does to one tree's points per pose (the same products as place_points). */
static inline void move_points(const double *m, const double *points, npy_intp n, double *out)
{
    for (npy_intp k = 0; k < n; k++) {
        double x = points[3 * k], y = points[3 * k + 1], z = points[3 * k + 2];
        for (int r = 0; r < 3; r++)
            out[3 * k + r] = m[4 * r] * x + m[4 * r + 1] * y + m[4 * r + 2] * z + m[4 * r + 3];
    }
}

/* ``out`` (N, 3) float64 = (N, 3) float64 or float32 ``points`` (any strides) moved by the
 * 4x4 float64 ``matrix``. */
#define PLACE_LOOP(T)                                                                    \
    for (npy_intp k = 0; k < n; k++) {                                                   \
        const char *row = base + k * s0;                                                 \
        double x = *(const T *)row, y = *(const T *)(row + s1), z = *(const T *)(row + 2 * s1); \
        for (int r = 0; r < 3; r++)                                                      \
            o[3 * k + r] = m[4 * r] * x + m[4 * r + 1] * y + m[4 * r + 2] * z + m[4 * r + 3]; \
    }
KERNEL(place_points)
{
    CP_NARGS(3);
    PyArrayObject *p = (PyArrayObject *)args[0];
    if (!PyArray_Check(args[0]) || PyArray_NDIM(p) != 2 || PyArray_DIM(p, 1) != 3 ||
        (PyArray_TYPE(p) != NPY_FLOAT64 && PyArray_TYPE(p) != NPY_FLOAT32)) {
        cp_fail("place_points", 0, "(N, 3) float64 or float32 points", args[0]);
        return NULL;
    }
    IN_F64(1, matrix, 2);
    OUT_F64(2, out, 2);
    npy_intp n = PyArray_DIM(p, 0), s0 = PyArray_STRIDE(p, 0), s1 = PyArray_STRIDE(p, 1);
    if (out.shape[0] != n || out.shape[1] != 3 || matrix.shape[0] != 4 || matrix.shape[1] != 4) {
        PyErr_SetString(PyExc_ValueError, "place_points: shapes differ");
        return NULL;
    }
    const char *base = PyArray_DATA(p);
    const double *m = F64(matrix);
    double *o = F64(out);
    int single = PyArray_TYPE(p) == NPY_FLOAT32;
    Py_BEGIN_ALLOW_THREADS
    if (single)
        PLACE_LOOP(float)
    else
        PLACE_LOOP(double)
    Py_END_ALLOW_THREADS
    Py_RETURN_NONE;
}

static PyMethodDef transform_methods[] = {
    ENTRY(matrix_problem, "(matrices (M, 4, 4) f8, rigid) -> first problem code (0: none)"),
    ENTRY(set_pose, "(matrix (4, 4), poses (N, 4, 4), versions (N,), i) -> problem code"),
    ENTRY(relative_poses, "(pose_a (E, 4, 4), pose_b (E, 4, 4), out): inv(a) @ b"),
    ENTRY(place_points, "(points (N, 3) f8/f4 any strides, matrix (4, 4), out (N, 3) f8)"),
    END_ENTRIES};
