/* cadpipe's compiled kernels: what every kernel file shares.
 *
 * The kernels are plain C over numpy arrays, compiled once when cadpipe is installed
 * (setup.py), so no process ever compiles them again: a fresh process starts in well
 * under a second (docs/performance.md, "Start-up"). All kernel files are compiled as one
 * translation unit (module.c includes them), so a helper written once here or in one
 * file is inlined wherever it is used.
 *
 * Arguments are checked for what the C code reads (dtype, dimensions, C order, writeable
 * outputs): a failed check is a TypeError naming the kernel and the argument, a mistake
 * of cadpipe's Python side, never of user input, which the Python side validates first.
 */
#ifndef CP_NATIVE_H
#define CP_NATIVE_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_21_API_VERSION
#define PY_ARRAY_UNIQUE_SYMBOL cadpipe_ARRAY_API
#include <numpy/arrayobject.h>

#include <math.h>
#include <stdint.h>
#include <string.h>

/* An array argument: its data and up to four extents. */
typedef struct {
    void *data;
    npy_intp shape[4];
    int ndim;
    npy_intp size;
} Arr;

#define F64(a) ((double *)(a).data)
#define I64(a) ((int64_t *)(a).data)
#define I32(a) ((int32_t *)(a).data)
#define I8(a) ((int8_t *)(a).data)
#define U8(a) ((uint8_t *)(a).data)
#define BOOL(a) ((npy_bool *)(a).data)

static int cp_fail(const char *kernel, int index, const char *what, PyObject *got)
{
    PyErr_Format(PyExc_TypeError, "cadpipe kernel %s, argument %d: need %s, got %R", kernel,
                 index, what, (PyObject *)Py_TYPE(got));
    return 0;
}

/* ``o`` as a C-ordered array of ``type`` (an NPY_* number) with ``ndim`` dimensions
 * (-1: any), writeable when ``write``. Returns 0 with a TypeError set when it is not. */
static int cp_array(PyObject *o, int type, int ndim, int write, Arr *out, const char *kernel,
                    int index)
{
    if (!PyArray_Check(o))
        return cp_fail(kernel, index, "a numpy array", o);
    PyArrayObject *a = (PyArrayObject *)o;
    if (PyArray_TYPE(a) != type || (ndim >= 0 && PyArray_NDIM(a) != ndim) ||
        PyArray_NDIM(a) > 4 || !PyArray_IS_C_CONTIGUOUS(a) || !PyArray_ISALIGNED(a) ||
        (write && !PyArray_ISWRITEABLE(a))) {
        char what[160];
        PyArray_Descr *want = PyArray_DescrFromType(type);
        snprintf(what, sizeof what, "a C-ordered%s %d-d array of %c (got %d-d of %c%s%s)",
                 write ? " writeable" : "", ndim, want ? want->type : '?', PyArray_NDIM(a),
                 PyArray_DESCR(a)->type, PyArray_IS_C_CONTIGUOUS(a) ? "" : ", not C-ordered",
                 (write && !PyArray_ISWRITEABLE(a)) ? ", read-only" : "");
        Py_XDECREF(want);
        PyErr_Format(PyExc_TypeError, "cadpipe kernel %s, argument %d: need %s", kernel, index,
                     what);
        return 0;
    }
    out->data = PyArray_DATA(a);
    out->ndim = PyArray_NDIM(a);
    out->size = PyArray_SIZE(a);
    for (int k = 0; k < 4; k++)
        out->shape[k] = k < out->ndim ? PyArray_DIM(a, k) : 1;
    return 1;
}

static int cp_double(PyObject *o, double *out, const char *kernel, int index)
{
    *out = PyFloat_AsDouble(o);
    if (*out == -1.0 && PyErr_Occurred()) {
        PyErr_Clear();
        return cp_fail(kernel, index, "a number", o);
    }
    return 1;
}

static int cp_long(PyObject *o, int64_t *out, const char *kernel, int index)
{
    long long v = PyLong_AsLongLong(o);
    if (v == -1 && PyErr_Occurred()) {
        PyErr_Clear();
        return cp_fail(kernel, index, "an integer", o);
    }
    *out = (int64_t)v;
    return 1;
}

static int cp_bool(PyObject *o, int *out, const char *kernel, int index)
{
    int v = PyObject_IsTrue(o);
    if (v < 0) {
        PyErr_Clear();
        return cp_fail(kernel, index, "a bool", o);
    }
    *out = v;
    return 1;
}

/* Argument unpacking, one line per argument: ``IN_F64(0, points, 2)`` reads argument 0
 * into ``Arr points``, a 2-d float64 array; ``OUT_`` ones must be writeable. */
#define CP_NARGS(n)                                                                      \
    if (nargs != (n)) {                                                                  \
        PyErr_Format(PyExc_TypeError, "cadpipe kernel %s takes %d arguments, got %zd",   \
                     __func__ + 2, (n), nargs);                                           \
        return NULL;                                                                     \
    }
#define CP_ARR(i, name, type, nd, w)                                                     \
    Arr name;                                                                            \
    if (!cp_array(args[i], type, nd, w, &name, __func__ + 2, i))                         \
        return NULL;
#define IN_F64(i, name, nd) CP_ARR(i, name, NPY_FLOAT64, nd, 0)
#define OUT_F64(i, name, nd) CP_ARR(i, name, NPY_FLOAT64, nd, 1)
#define IN_F32(i, name, nd) CP_ARR(i, name, NPY_FLOAT32, nd, 0)
#define IN_I64(i, name, nd) CP_ARR(i, name, NPY_INT64, nd, 0)
#define OUT_I64(i, name, nd) CP_ARR(i, name, NPY_INT64, nd, 1)
#define IN_I32(i, name, nd) CP_ARR(i, name, NPY_INT32, nd, 0)
#define OUT_I32(i, name, nd) CP_ARR(i, name, NPY_INT32, nd, 1)
#define IN_U8(i, name, nd) CP_ARR(i, name, NPY_UINT8, nd, 0)
#define OUT_U8(i, name, nd) CP_ARR(i, name, NPY_UINT8, nd, 1)
#define IN_I8(i, name, nd) CP_ARR(i, name, NPY_INT8, nd, 0)
#define OUT_I8(i, name, nd) CP_ARR(i, name, NPY_INT8, nd, 1)
#define IN_BOOL(i, name, nd) CP_ARR(i, name, NPY_BOOL, nd, 0)
#define OUT_BOOL(i, name, nd) CP_ARR(i, name, NPY_BOOL, nd, 1)
#define IN_DOUBLE(i, name)                                                               \
    double name;                                                                         \
    if (!cp_double(args[i], &name, __func__ + 2, i))                                     \
        return NULL;
#define IN_LONG(i, name)                                                                 \
    int64_t name;                                                                        \
    if (!cp_long(args[i], &name, __func__ + 2, i))                                       \
        return NULL;
#define IN_FLAG(i, name)                                                                 \
    int name;                                                                            \
    if (!cp_bool(args[i], &name, __func__ + 2, i))                                       \
        return NULL;

/* A kernel's Python entry point: ``KERNEL(name)`` defines ``k_name``, which the file's
 * method table lists as ``ENTRY(name, "docstring")``. */
#define KERNEL(name) static PyObject *k_##name(PyObject *self, PyObject *const *args, \
                                               Py_ssize_t nargs)
#define ENTRY(name, doc) {#name, (PyCFunction)(void (*)(void))k_##name, METH_FASTCALL, doc}
#define END_ENTRIES {NULL, NULL, 0, NULL}

/* A new C-ordered array of ``type`` with ``ndim`` extents ``dims``; NULL (MemoryError
 * set) when there is no room. */
static PyArrayObject *cp_new(int ndim, const npy_intp *dims, int type)
{
    return (PyArrayObject *)PyArray_SimpleNew(ndim, (npy_intp *)dims, type);
}

/* Python's min and max of two numbers (the first unless the second is smaller / larger:
 * min(nan, 1) is nan, min(1, nan) is 1), as the kernels were first written. */
static inline double cp_min(double a, double b) { return b < a ? b : a; }
static inline double cp_max(double a, double b) { return b > a ? b : a; }
static inline double cp_clip01(double v) { return v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v); }
static inline int64_t cp_imin(int64_t a, int64_t b) { return a < b ? a : b; }
static inline int64_t cp_imax(int64_t a, int64_t b) { return a > b ? a : b; }
/* Python's // and % of integers (rounding towards -inf; b != 0) */
static inline int64_t cp_floordiv(int64_t a, int64_t b)
{
    int64_t q = a / b;
    return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}
static inline int64_t cp_mod(int64_t a, int64_t b)
{
    int64_t r = a % b;
    return (r != 0 && ((r < 0) != (b < 0))) ? r + b : r;
}

#endif
