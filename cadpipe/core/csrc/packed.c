/* A world's arrays as one record, so that one state is one kernel call with one argument
 * (cadpipe.collision.packed): refresh reads some fifty arrays, whose checks as separate
 * arguments would cost more than a pipe's whole yes/no walk. The record holds a reference
 * to each array and its data pointer, checked once when it is made: the scene's poses and
 * pose versions, the checker's placed bounds and stored answers are the memory the Python
 * side reads. */
#include "native.h"

/* How a field's first extent is tied to the world: any, N objects, N + 1 offsets, P pairs,
 * or 2 (the hits). */
enum { ANY, OBJECTS, OFFSETS, PAIRS, TWO };

/* The record's fields, in the order pack takes them: X(name, C type, numpy type, ndim,
 * inner extents (0: none), first extent). The one list: cadpipe.collision.packed reads it
 * through packed_fields(). */
#define PACKED_FIELDS(X)                                                                  \
    /* the 18-DOPs' support points of every object (object i's at starts[i]:starts[i+1]) */ \
    X(points, double, NPY_FLOAT64, 2, 3, 0, ANY)                                          \
    X(pads, double, NPY_FLOAT64, 1, 0, 0, ANY)                                            \
    X(starts, int64_t, NPY_INT64, 1, 0, 0, OFFSETS)                                       \
    /* per object: rounding slack, the local OBB, whether a chain, whether closed */      \
    X(slack, double, NPY_FLOAT64, 1, 0, 0, OBJECTS)                                       \
    X(obb_centre, double, NPY_FLOAT64, 2, 3, 0, OBJECTS)                                  \
    X(obb_axes, double, NPY_FLOAT64, 3, 3, 3, OBJECTS)                                    \
    X(half, double, NPY_FLOAT64, 2, 3, 0, OBJECTS)                                        \
    X(chain, npy_bool, NPY_BOOL, 1, 0, 0, OBJECTS)                                        \
    X(closed, npy_bool, NPY_BOOL, 1, 0, 0, OBJECTS)                                       \
    /* the pair table (np.triu_indices order) */                                          \
    X(first, int64_t, NPY_INT64, 1, 0, 0, PAIRS)                                          \
    X(second, int64_t, NPY_INT64, 1, 0, 0, PAIRS)                                         \
    X(same, npy_bool, NPY_BOOL, 1, 0, 0, PAIRS)                                           \
    X(allowed, npy_bool, NPY_BOOL, 1, 0, 0, PAIRS)                                        \
    /* the convex pieces (cadpipe.collision.convex.Pieces.arrays()) */                    \
    X(piece_points, double, NPY_FLOAT64, 2, 3, 0, ANY)                                    \
    X(piece_pads, double, NPY_FLOAT64, 1, 0, 0, ANY)                                      \
    X(piece_starts, int64_t, NPY_INT64, 1, 0, 0, ANY)                                     \
    X(piece_centre, double, NPY_FLOAT64, 2, 3, 0, ANY)                                    \
    X(piece_radius, double, NPY_FLOAT64, 1, 0, 0, ANY)                                    \
    X(pieces, int64_t, NPY_INT64, 1, 0, 0, OFFSETS)                                       \
    /* every chain's capsule tree (hierarchy.CapsuleTree), object i's nodes at            \
     * tree_at[i]:tree_at[i+1], its points at tree_points_at[i]:tree_points_at[i+1] */     \
    X(tree_table, double, NPY_FLOAT64, 2, 10, 0, ANY)                                     \
    X(tree_index, int64_t, NPY_INT64, 2, 3, 0, ANY)                                       \
    X(tree_points, double, NPY_FLOAT64, 2, 3, 0, ANY)                                     \
    X(tree_at, int64_t, NPY_INT64, 1, 0, 0, OFFSETS)                                      \
    X(tree_points_at, int64_t, NPY_INT64, 1, 0, 0, OFFSETS)                               \
    X(tree_depth, int64_t, NPY_INT64, 1, 0, 0, OBJECTS)                                   \
    /* the triangle trees (chain_mesh.TriangleTree) of meshes paired with a chain */      \
    X(mesh_boxes, double, NPY_FLOAT64, 2, 7, 0, ANY)                                      \
    X(mesh_frames, double, NPY_FLOAT64, 2, 15, 0, ANY)                                    \
    X(mesh_triangles, double, NPY_FLOAT64, 2, 9, 0, ANY)                                  \
    X(boxes_at, int64_t, NPY_INT64, 1, 0, 0, OFFSETS)                                     \
    X(frames_at, int64_t, NPY_INT64, 1, 0, 0, OFFSETS)                                    \
    X(triangles_at, int64_t, NPY_INT64, 1, 0, 0, OFFSETS)                                 \
    X(mesh_depth, int64_t, NPY_INT64, 1, 0, 0, OBJECTS)                                   \
    /* the containment prefilter: a chain's probes and extremes, a mesh's inside_filter */ \
    X(probes, double, NPY_FLOAT64, 2, 3, 0, ANY)                                          \
    X(probes_at, int64_t, NPY_INT64, 1, 0, 0, OFFSETS)                                    \
    X(extremes, double, NPY_FLOAT64, 3, 18, 3, OBJECTS)                                   \
    X(inside_lo, double, NPY_FLOAT64, 2, 3, 0, OBJECTS)                                   \
    X(inside_hi, double, NPY_FLOAT64, 2, 3, 0, OBJECTS)                                   \
    X(inside_low, double, NPY_FLOAT64, 2, 9, 0, OBJECTS)                                  \
    X(inside_high, double, NPY_FLOAT64, 2, 9, 0, OBJECTS)                                 \
    X(inside_slack, double, NPY_FLOAT64, 1, 0, 0, OBJECTS)                                \
    /* where the objects stand: the scene's poses and pose versions */                    \
    X(poses, double, NPY_FLOAT64, 3, 4, 4, OBJECTS)                                       \
    X(versions, int64_t, NPY_INT64, 1, 0, 0, OBJECTS)                                     \
    /* each object's placed bounds and the pose version they were placed at */            \
    X(placed_at, int64_t, NPY_INT64, 1, 0, 0, OBJECTS)                                    \
    X(kdop, double, NPY_FLOAT64, 3, 2, 9, OBJECTS)                                        \
    X(centre, double, NPY_FLOAT64, 2, 3, 0, OBJECTS)                                      \
    X(axes, double, NPY_FLOAT64, 3, 3, 3, OBJECTS)                                        \
    /* each pair's last answer and the pose versions it holds for */                      \
    X(at_a, int64_t, NPY_INT64, 1, 0, 0, PAIRS)                                           \
    X(at_b, int64_t, NPY_INT64, 1, 0, 0, PAIRS)                                           \
    X(code, int8_t, NPY_INT8, 1, 0, 0, PAIRS)                                             \
    X(colliding, npy_bool, NPY_BOOL, 1, 0, 0, PAIRS)                                      \
    /* the last call's pairs left to Python (pair indices, in order; the second object's  \
     * pose in the first's frame), and whether a self pair, another pair collides */      \
    X(left, int64_t, NPY_INT64, 1, 0, 0, PAIRS)                                           \
    X(left_poses, double, NPY_FLOAT64, 3, 4, 4, PAIRS)                                    \
    X(hits, npy_bool, NPY_BOOL, 1, 0, 0, TWO)

/* F_name: each field's place in the list; PACKED_COUNT: how many */
enum {
#define PACKED_INDEX(name, T, type, nd, w1, w2, length) F_##name,
    PACKED_FIELDS(PACKED_INDEX)
#undef PACKED_INDEX
    PACKED_COUNT
};

/* The record: each field's array (a reference) and its data; ``n`` objects, ``p`` pairs;
 * ``certify``: no hull stage, and every exact pair is left to Python (the certificate). */
typedef struct {
    PyObject_HEAD
    PyObject *arrays[PACKED_COUNT];
#define PACKED_MEMBER(name, T, type, nd, w1, w2, length) T *name;
    PACKED_FIELDS(PACKED_MEMBER)
#undef PACKED_MEMBER
    npy_intp n, p;
    int certify;
} Packed;

static void packed_dealloc(PyObject *self)
{
    Packed *w = (Packed *)self;
    for (int k = 0; k < PACKED_COUNT; k++)
        Py_XDECREF(w->arrays[k]);
    Py_TYPE(self)->tp_free(self);
}

static PyTypeObject packed_type = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "cadpipe.core._kernels.Packed",
    .tp_basicsize = sizeof(Packed),
    .tp_dealloc = packed_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "A world's arrays for refresh (cadpipe.collision.packed); made by pack().",
};

/* The record of argument ``at``, or NULL with a TypeError: one pointer comparison, what a
 * per-state kernel pays for some fifty arrays. */
static inline Packed *packed_of(PyObject *const *args, int at, const char *kernel)
{
    if (Py_TYPE(args[at]) != &packed_type) {
        cp_fail(kernel, at, "a Packed record (native.pack)", args[at]);
        return NULL;
    }
    return (Packed *)args[at];
}

static int packed_bad(const char *what)
{
    PyErr_Format(PyExc_ValueError, "pack: %s", what);
    return 0;
}

/* Whether ``offsets`` (N + 1) rise from 0 to at most ``rows``. */
static int offsets_ok(const int64_t *offsets, npy_intp n, npy_intp rows)
{
    if (offsets[0] < 0 || offsets[n] > rows)
        return 0;
    for (npy_intp i = 0; i < n; i++)
        if (offsets[i + 1] < offsets[i])
            return 0;
    return 1;
}

/* What the kernels read without checking again: the extents that tie the fields together,
 * the offsets into the concatenated arrays, the pair table's objects, each packed tree's
 * size and the points its chords index. */
static int packed_consistent(const Packed *w, const Arr *arr)
{
    npy_intp n = w->n;
    if (!offsets_ok(w->starts, n, arr[F_points].shape[0]) ||
        arr[F_pads].shape[0] != arr[F_points].shape[0] ||
        !offsets_ok(w->pieces, n, arr[F_piece_starts].shape[0] - 1) ||
        arr[F_piece_starts].shape[0] < 1 ||
        !offsets_ok(w->piece_starts, arr[F_piece_starts].shape[0] - 1,
                    arr[F_piece_points].shape[0]) ||
        arr[F_piece_pads].shape[0] != arr[F_piece_points].shape[0] ||
        arr[F_piece_centre].shape[0] != arr[F_piece_starts].shape[0] - 1 ||
        arr[F_piece_radius].shape[0] != arr[F_piece_starts].shape[0] - 1 ||
        !offsets_ok(w->tree_at, n, arr[F_tree_table].shape[0]) ||
        arr[F_tree_index].shape[0] != arr[F_tree_table].shape[0] ||
        !offsets_ok(w->tree_points_at, n, arr[F_tree_points].shape[0]) ||
        !offsets_ok(w->boxes_at, n, arr[F_mesh_boxes].shape[0]) ||
        !offsets_ok(w->frames_at, n, arr[F_mesh_frames].shape[0]) ||
        !offsets_ok(w->triangles_at, n, arr[F_mesh_triangles].shape[0]) ||
        !offsets_ok(w->probes_at, n, arr[F_probes].shape[0]))
        return packed_bad("offsets that do not fit their arrays");
    for (npy_intp k = 0; k < w->p; k++)
        if (w->first[k] < 0 || w->first[k] >= n || w->second[k] < 0 || w->second[k] >= n)
            return packed_bad("a pair of objects that are not there");
    for (npy_intp i = 0; i < n; i++) {
        int64_t nodes = w->tree_at[i + 1] - w->tree_at[i], depth = w->tree_depth[i];
        int64_t points = w->tree_points_at[i + 1] - w->tree_points_at[i];
        if (nodes) {
            if (depth < 0 || depth > TREE_DEPTH_MAX || nodes != ((int64_t)2 << depth) - 1)
                return packed_bad("a capsule tree of another size than its depth");
            const int64_t *index = w->tree_index + 3 * w->tree_at[i];
            for (int64_t k = 0; k < nodes; k++)
                if (index[3 * k] < 0 || index[3 * k] >= points || index[3 * k + 1] < 0 ||
                    index[3 * k + 1] >= points)
                    return packed_bad("a chord end outside its tree's points");
        }
        int64_t boxes = w->boxes_at[i + 1] - w->boxes_at[i];
        depth = w->mesh_depth[i];
        if (boxes && (depth < 0 || depth > TREE_DEPTH_MAX ||
                      boxes != ((int64_t)2 << depth) - 1 ||
                      w->frames_at[i + 1] - w->frames_at[i] != ((int64_t)1 << depth) - 1 ||
                      w->triangles_at[i + 1] - w->triangles_at[i] != (int64_t)1 << depth))
            return packed_bad("a triangle tree of another size than its depth");
        if (boxes && w->chain[i])
            return packed_bad("a triangle tree for a chain");
        if ((w->chain[i] != 0) != (nodes != 0))
            return packed_bad("a chain without a capsule tree, or a mesh with one");
    }
    return 1;
}

/* pack(points, pads, ..., hits, certify): the record of the fields in PACKED_FIELDS order
 * (each of its dtype, ndim and inner extents, C-ordered: shared, not copied), then
 * ``certify``. The kernels write only the fields from ``placed_at`` on, which must be
 * writeable; the scene's poses and versions before them may be read-only views. */
KERNEL(pack)
{
    CP_NARGS(PACKED_COUNT + 1);
    Arr arr[PACKED_COUNT];
    static const struct { const char *name; int type, ndim, w1, w2, length; } fields[] = {
#define PACKED_SPEC(name, T, type, nd, w1, w2, length) {#name, type, nd, w1, w2, length},
        PACKED_FIELDS(PACKED_SPEC)
#undef PACKED_SPEC
    };
    for (int k = 0; k < PACKED_COUNT; k++) {
        if (!cp_array(args[k], fields[k].type, fields[k].ndim, k >= F_placed_at, &arr[k], "pack",
                      k)) {
            PyObject *type, *value, *trace;          /* name the field, keep the details */
            PyErr_Fetch(&type, &value, &trace);
            PyErr_Format(PyExc_TypeError, "packed field %s: %S", fields[k].name, value);
            Py_XDECREF(type);
            Py_XDECREF(value);
            Py_XDECREF(trace);
            return NULL;
        }
        if ((fields[k].w1 && arr[k].shape[1] != fields[k].w1) ||
            (fields[k].w2 && arr[k].shape[2] != fields[k].w2)) {
            PyErr_Format(PyExc_ValueError, "pack: field %s has the wrong inner extents",
                         fields[k].name);
            return NULL;
        }
    }
    IN_FLAG(PACKED_COUNT, certify);
    npy_intp n = arr[F_slack].shape[0], p = arr[F_first].shape[0];
    for (int k = 0; k < PACKED_COUNT; k++) {
        int length = fields[k].length;
        npy_intp want = length == OBJECTS ? n : length == OFFSETS ? n + 1 : length == PAIRS ? p
                        : 2;
        if (length != ANY && arr[k].shape[0] != want) {
            PyErr_Format(PyExc_ValueError, "pack: field %s has %zd rows, needs %zd",
                         fields[k].name, (Py_ssize_t)arr[k].shape[0], (Py_ssize_t)want);
            return NULL;
        }
    }
    Packed *w = PyObject_New(Packed, &packed_type);
    if (!w)
        return NULL;
    int k = 0;
#define PACKED_SET(name, T, type, nd, w1, w2, length)                                     \
    w->arrays[k] = Py_NewRef(args[k]);                                                    \
    w->name = (T *)arr[k].data;                                                           \
    k++;
    PACKED_FIELDS(PACKED_SET)
#undef PACKED_SET
    w->n = n, w->p = p, w->certify = certify;
    if (!packed_consistent(w, arr)) {
        Py_DECREF(w);
        return NULL;
    }
    return (PyObject *)w;
}

/* packed_fields() -> ((name, dtype, ndim), ...): the fields pack takes before certify */
KERNEL(packed_fields)
{
    CP_NARGS(0);
    static const struct { const char *name; int type, ndim; } fields[] = {
#define PACKED_NAME(name, T, type, nd, w1, w2, length) {#name, type, nd},
        PACKED_FIELDS(PACKED_NAME)
#undef PACKED_NAME
    };
    PyObject *out = PyTuple_New(PACKED_COUNT);
    for (int k = 0; out && k < PACKED_COUNT; k++) {
        PyArray_Descr *descr = PyArray_DescrFromType(fields[k].type);
        PyObject *item = descr ? Py_BuildValue("(sOi)", fields[k].name, (PyObject *)descr,
                                               fields[k].ndim) : NULL;
        Py_XDECREF(descr);
        if (!item) {
            Py_DECREF(out);
            return NULL;
        }
        PyTuple_SET_ITEM(out, k, item);
    }
    return out;
}

static PyMethodDef packed_methods[] = {
    ENTRY(pack, "(*fields in packed_fields() order, certify) -> Packed: a world's arrays"),
    ENTRY(packed_fields, "() -> ((name, dtype, ndim), ...): the fields of pack, in order"),
    END_ENTRIES};
