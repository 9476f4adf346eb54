/* Passes of cadpipe's PLY and OBJ files (cadpipe.io.trimesh_formats): the split of the
 * vertices where colours meet (PLY stores a colour per vertex) and the word count of each
 * line of an OBJ run. */
#include "native.h"

/* A 1-d int32 or int64 array of labels (``wide`` set for int64). */
static int meshfiles_labels(PyObject *o, Arr *out, int *wide, int index)
{
    *wide = !(PyArray_Check(o) && PyArray_TYPE((PyArrayObject *)o) == NPY_INT32);
    return cp_array(o, *wide ? NPY_INT64 : NPY_INT32, 1, 0, out, "copies_per_label", index);
}

/* The copies made so far: the vertex each repeats, its label and the next copy of the same
 * vertex (-1: none), grown by doubling (linear in total). */
typedef struct {
    int64_t *of, *label, *next;
    npy_intp count, room;
} Copies;

static int copies_grow(Copies *c)
{
    npy_intp room = c->room ? 2 * c->room : 16;
    int64_t *of = PyMem_RawRealloc(c->of, sizeof(int64_t) * (size_t)room);
    if (!of)
        return 0;
    c->of = of;
    int64_t *label = PyMem_RawRealloc(c->label, sizeof(int64_t) * (size_t)room);
    if (!label)
        return 0;
    c->label = label;
    int64_t *next = PyMem_RawRealloc(c->next, sizeof(int64_t) * (size_t)room);
    if (!next)
        return 0;
    c->next = next;
    c->room = room;
    return 1;
}

/* The pass of copies_per_label over ``nf`` faces: fills ``out`` and ``own`` (V) and
 * ``copies``; ``first_copy`` (V) is scratch. Returns 0, 1 when out of memory, 2 for a
 * face index outside [0, nv). Inlined with constant ``lwide`` and ``owide``, so each
 * pair of index types gets a loop of its own. */
static inline int copies_pass(const int64_t *fc, npy_intp nf, const void *labels, int lwide,
                              int64_t nv, void *out, int owide, int64_t *own,
                              int64_t *first_copy, Copies *copies)
{
    for (int64_t v = 0; v < nv; v++)
        own[v] = first_copy[v] = -1;
    int64_t *label_of = NULL, *next = NULL;         /* copies->label, ->next while it holds */
    for (npy_intp f = 0; f < nf; f++) {
        int64_t label = lwide ? ((const int64_t *)labels)[f] : ((const int32_t *)labels)[f];
        for (int k = 0; k < 3; k++) {
            int64_t v = fc[3 * f + k], slot;
            if (v < 0 || v >= nv)
                return 2;
            if (own[v] < 0)
                own[v] = label;
            if (own[v] == label)
                slot = v;
            else {
                int64_t c = first_copy[v];
                while (c >= 0 && label_of[c] != label)
                    c = next[c];
                if (c < 0) {
                    if (copies->count == copies->room) {
                        if (!copies_grow(copies))
                            return 1;
                        label_of = copies->label;
                        next = copies->next;
                    }
                    c = copies->count++;
                    copies->of[c] = v;
                    label_of[c] = label;
                    next[c] = first_copy[v];
                    first_copy[v] = c;
                }
                slot = nv + c;
            }
            if (owide)
                ((int64_t *)out)[3 * f + k] = slot;
            else
                ((int32_t *)out)[3 * f + k] = (int32_t)slot;
        }
    }
    for (int64_t v = 0; v < nv; v++)
        if (own[v] < 0)
            own[v] = 0;
    return 0;
}

/* copies_per_label(faces (F, 3) int64, labels (F,) int32|int64, n_vertices, out (F, 3)
 * int32|int64) -> (own_label (V,), copy_of (E,), copy_label (E,)) int64: fill ``out`` with
 * faces whose corners each reach a vertex of their face's label, in one linear pass. A
 * vertex keeps its index for the first label that reaches it; each further label at it
 * gets a copy numbered from ``n_vertices`` on (found through a short chain per vertex: as
 * many links as colours meet there). ``own_label``: each vertex's label as it is (0
 * where unused); ``copy_of``, ``copy_label``: the vertex each copy repeats and its
 * label. */
KERNEL(copies_per_label)
{
    CP_NARGS(4);
    IN_I64(0, faces, 2);
    Arr labels, out;
    int lwide, owide;
    if (!meshfiles_labels(args[1], &labels, &lwide, 1))
        return NULL;
    IN_LONG(2, n_vertices);
    owide = !(PyArray_Check(args[3]) && PyArray_TYPE((PyArrayObject *)args[3]) == NPY_INT32);
    if (!cp_array(args[3], owide ? NPY_INT64 : NPY_INT32, 2, 1, &out, "copies_per_label", 3))
        return NULL;
    npy_intp nf = faces.shape[0];
    if (faces.shape[1] != 3 || labels.size != nf || out.shape[0] != nf || out.shape[1] != 3 ||
        n_vertices < 0) {
        PyErr_SetString(PyExc_ValueError, "copies_per_label: faces (F, 3), labels (F,), "
                                          "out (F, 3)");
        return NULL;
    }
    npy_intp dims[1] = {(npy_intp)n_vertices};
    PyArrayObject *own_arr = cp_new(1, dims, NPY_INT64);
    int64_t *first_copy = PyMem_RawMalloc(sizeof(int64_t) * (size_t)(n_vertices + 1));
    if (!own_arr || !first_copy) {
        Py_XDECREF(own_arr);
        PyMem_RawFree(first_copy);
        return PyErr_NoMemory();
    }
    int64_t *own = PyArray_DATA(own_arr);
    const int64_t *fc = I64(faces);
    Copies copies = {NULL, NULL, NULL, 0, 0};
    int failed;
    Py_BEGIN_ALLOW_THREADS
    if (lwide)
        failed = owide ? copies_pass(fc, nf, labels.data, 1, n_vertices, out.data, 1, own,
                                     first_copy, &copies)
                       : copies_pass(fc, nf, labels.data, 1, n_vertices, out.data, 0, own,
                                     first_copy, &copies);
    else
        failed = owide ? copies_pass(fc, nf, labels.data, 0, n_vertices, out.data, 1, own,
                                     first_copy, &copies)
                       : copies_pass(fc, nf, labels.data, 0, n_vertices, out.data, 0, own,
                                     first_copy, &copies);
    Py_END_ALLOW_THREADS
    PyMem_RawFree(first_copy);
    PyArrayObject *of_arr = NULL, *label_arr = NULL;
    if (!failed) {
        npy_intp cdims[1] = {copies.count};
        of_arr = cp_new(1, cdims, NPY_INT64);
        label_arr = cp_new(1, cdims, NPY_INT64);
        if (of_arr && label_arr && copies.count) {
            memcpy(PyArray_DATA(of_arr), copies.of, sizeof(int64_t) * (size_t)copies.count);
            memcpy(PyArray_DATA(label_arr), copies.label,
                   sizeof(int64_t) * (size_t)copies.count);
        }
    }
    PyMem_RawFree(copies.of);
    PyMem_RawFree(copies.label);
    PyMem_RawFree(copies.next);
    if (failed || !of_arr || !label_arr) {
        Py_DECREF(own_arr);
        Py_XDECREF(of_arr);
        Py_XDECREF(label_arr);
        if (failed == 2)
            PyErr_SetString(PyExc_IndexError, "copies_per_label: a face's vertex index is "
                                              "outside [0, n_vertices)");
        else if (failed == 1)
            PyErr_NoMemory();
        return NULL;
    }
    return Py_BuildValue("NNN", own_arr, of_arr, label_arr);
}

/* Whether byte ``c`` is one of C's white space: " \t\n\v\f\r". */
static inline unsigned meshfiles_space(unsigned c)
{
    return (c == 32) | ((uint8_t)(c - 9) < 5);
}

/* How many words b[start:end] holds: bytes not blank after a blank one (or the start),
 * blank by meshfiles_space (compares, which vectorize, where a table does not). */
static int64_t meshfiles_words(const uint8_t *b, int64_t start, int64_t end)
{
    if (start >= end)
        return 0;
    int64_t words = !meshfiles_space(b[start]);
    for (int64_t i = start + 1; i < end; i++)
        words += meshfiles_space(b[i - 1]) & (meshfiles_space(b[i]) ^ 1u);
    return words;
}

/* meshfiles_words with the blanks of ``blank`` (256 entries, 0 or 1). */
static int64_t meshfiles_words_by(const uint8_t *b, int64_t start, int64_t end,
                                  const uint8_t *blank)
{
    int64_t words = 0;
    unsigned before = 1;                    /* the line's start counts as a blank */
    for (int64_t i = start; i < end; i++) {
        unsigned here = blank[b[i]];
        words += before & (here ^ 1u);
        before = here;
    }
    return words;
}

/* words_per_line(buf (N,) uint8, line_starts (L,) int64, space (256,) bool) -> (L,)
 * int64: how many words (runs of bytes that are not ``space``) each line of ``buf``
 * holds; line i runs from line_starts[i] to the next start (the last to the end). */
KERNEL(words_per_line)
{
    CP_NARGS(3);
    IN_U8(0, buf, 1);
    IN_I64(1, line_starts, 1);
    IN_BOOL(2, space, 1);
    npy_intp lines = line_starts.size;
    const int64_t *starts = I64(line_starts);
    int valid = space.size == 256;
    for (npy_intp i = 0; valid && i < lines; i++)
        valid = starts[i] >= 0 && starts[i] <= buf.size &&
                (i + 1 == lines || starts[i + 1] >= starts[i]);
    if (!valid) {
        PyErr_SetString(PyExc_ValueError, "words_per_line: ascending line starts within "
                                          "the buffer, a 256-entry space table");
        return NULL;
    }
    npy_intp dims[1] = {lines};
    PyArrayObject *counts_arr = cp_new(1, dims, NPY_INT64);
    if (!counts_arr)
        return NULL;
    int64_t *counts = PyArray_DATA(counts_arr);
    const uint8_t *b = U8(buf);
    uint8_t blank[256];                     /* 0 or 1: a word starts at a 0 after a 1 */
    int ascii = 1;                          /* the table is C's isspace: " \t\n\v\f\r" */
    for (int c = 0; c < 256; c++) {
        blank[c] = BOOL(space)[c] != 0;
        ascii &= blank[c] == meshfiles_space(c);
    }
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp line = 0; line < lines; line++) {
        int64_t start = starts[line], end = line + 1 < lines ? starts[line + 1] : buf.size;
        counts[line] = ascii ? meshfiles_words(b, start, end)
                             : meshfiles_words_by(b, start, end, blank);
    }
    Py_END_ALLOW_THREADS
    return (PyObject *)counts_arr;
}

static PyMethodDef meshfiles_methods[] = {
    ENTRY(copies_per_label, "Faces whose corners reach a vertex of their label (PLY colours)."),
    ENTRY(words_per_line, "How many blank-separated words each line holds (OBJ runs)."),
    END_ENTRIES};
