/* Forward kinematics down a joint tree (cadpipe.collision.kinematics explains the terms).
 *
 * Joint j's local transform is ``terms[j, 0] + sin(a) terms[j, 1] + (1 - cos(a))
 * terms[j, 2] + s terms[j, 3]`` (Rodrigues' formula with the origin's products
 * precomputed; a = value for a turning joint, s = value for a sliding one), multiplied
 * down the tree parents first. One configuration's chain is a few hundred flops: these
 * are called per state (place_links) and per advancement step (motion.c), so the
 * scratch of a usual robot lives on the stack. */
#include "native.h"

/* A robot's joint arrays (robot._kinematics): terms (J, 4, 4, 4), kinds (J, 2) (1.0 for
 * turning in column 0, sliding in column 1), links (J, 2) (parent, child link index,
 * parents first). */
typedef struct {
    const double *terms, *kinds;
    const int64_t *links;
    npy_intp joints;
} Joints;

/* Every link's world pose into ``pose`` ((J + 1) * 16, row by row) at joint values
 * ``values`` (J,), link 0 at ``base`` (16). */
static void chain_pose(const Joints *k, const double *values, const double *base, double *pose)
{
    double local[16];
    memcpy(pose, base, 16 * sizeof(double));
    for (npy_intp j = 0; j < k->joints; j++) {
        double angle = values[j] * k->kinds[2 * j], shift = values[j] * k->kinds[2 * j + 1];
        double s = sin(angle), c = 1.0 - cos(angle);
        const double *term = k->terms + 64 * j;
        for (int e = 0; e < 16; e++)
            local[e] = term[e] + s * term[16 + e] + c * term[32 + e] + shift * term[48 + e];
        const double *up = pose + 16 * k->links[2 * j];
        double *down = pose + 16 * k->links[2 * j + 1];
        for (int r = 0; r < 4; r++)
            for (int col = 0; col < 4; col++)
                down[4 * r + col] = up[4 * r] * local[col] + up[4 * r + 1] * local[4 + col] +
                                    up[4 * r + 2] * local[8 + col] +
                                    up[4 * r + 3] * local[12 + col];
    }
}

/* ``out`` (G, 4, 4) = the poses of links ``geometry`` (G,) at ``values`` (J,); ``pose``
 * ((J + 1) * 16) is scratch. */
static void chain_poses_one(const Joints *k, const double *values, const double *base,
                            const int64_t *geometry, npy_intp count, double *pose, double *out)
{
    chain_pose(k, values, base, pose);
    for (npy_intp g = 0; g < count; g++)
        memcpy(out + 16 * g, pose + 16 * geometry[g], 16 * sizeof(double));
}

/* A robot's actuated-joint arrays: limits (2, A), actuated (A,) joint positions, mimics
 * (M, 2) (mimic joint, joint followed), mimic_terms (M, 2) (multiplier, offset). */
typedef struct {
    const double *limits, *mimic_terms;
    const int64_t *actuated, *mimics;
    npy_intp actuators, count_mimics;
} Actuators;

/* Every joint's value ``out`` (J,) from the actuated ones ``q`` (A,) of configuration
 * ``c``: fixed joints 0, mimics derived in joint order (a mimic of a mimic after its
 * source). -1, or the flat index ``c * A + a`` of the first value outside its limits
 * (NaN included; 1e-9 of slack). */
static int64_t joint_row(const Actuators *a, const double *q, int64_t c, npy_intp joints,
                         double *out)
{
    for (npy_intp j = 0; j < joints; j++)
        out[j] = 0.0;
    for (npy_intp i = 0; i < a->actuators; i++) {
        double v = q[i];
        if (!(v >= a->limits[i] - 1e-9 && v <= a->limits[a->actuators + i] + 1e-9))
            return c * a->actuators + i;
        out[a->actuated[i]] = v;
    }
    for (npy_intp m = 0; m < a->count_mimics; m++)
        out[a->mimics[2 * m]] = a->mimic_terms[2 * m] * out[a->mimics[2 * m + 1]] +
                                a->mimic_terms[2 * m + 1];
    return -1;
}

static int joints_of(PyObject *const *args, int first, Joints *k, const char *kernel)
{
    Arr terms, kinds, links;
    if (!cp_array(args[first], NPY_FLOAT64, 4, 0, &terms, kernel, first) ||
        !cp_array(args[first + 1], NPY_FLOAT64, 2, 0, &kinds, kernel, first + 1) ||
        !cp_array(args[first + 2], NPY_INT64, 2, 0, &links, kernel, first + 2))
        return 0;
    if (kinds.shape[0] != terms.shape[0] || links.shape[0] != terms.shape[0]) {
        PyErr_Format(PyExc_ValueError, "cadpipe kernel %s: terms, kinds and links differ in "
                     "joints", kernel);
        return 0;
    }
    k->terms = F64(terms), k->kinds = F64(kinds), k->links = I64(links);
    k->joints = terms.shape[0];
    return 1;
}

static int actuators_of(PyObject *const *args, int first, Actuators *a, const char *kernel)
{
    Arr limits, actuated, mimics, mimic_terms;
    if (!cp_array(args[first], NPY_FLOAT64, 2, 0, &limits, kernel, first) ||
        !cp_array(args[first + 1], NPY_INT64, 1, 0, &actuated, kernel, first + 1) ||
        !cp_array(args[first + 2], NPY_INT64, 2, 0, &mimics, kernel, first + 2) ||
        !cp_array(args[first + 3], NPY_FLOAT64, 2, 0, &mimic_terms, kernel, first + 3))
        return 0;
    a->limits = F64(limits), a->actuated = I64(actuated), a->mimics = I64(mimics);
    a->mimic_terms = F64(mimic_terms);
    a->actuators = actuated.shape[0], a->count_mimics = mimics.shape[0];
    return 1;
}

/* Scratch of (J + 1) poses: on the stack for up to 31 joints, else allocated. */
#define POSE_STACK 32
typedef struct {
    double stack[16 * POSE_STACK];
    double *pose;
} PoseScratch;

static double *pose_scratch(PoseScratch *s, npy_intp joints)
{
    s->pose = joints + 1 <= POSE_STACK ? s->stack
                                       : PyMem_RawMalloc(16 * (joints + 1) * sizeof(double));
    return s->pose;
}

static void pose_scratch_free(PoseScratch *s)
{
    if (s->pose != s->stack)
        PyMem_RawFree(s->pose);
}

/* chain_poses(values (C, J), terms, kinds, links, base (4, 4), geometry (G,)) -> (C, G, 4, 4) */
KERNEL(chain_poses)
{
    CP_NARGS(6);
    IN_F64(0, values, 2);
    Joints k;
    if (!joints_of(args, 1, &k, "chain_poses"))
        return NULL;
    IN_F64(4, base, 2);
    IN_I64(5, geometry, 1);
    if (values.shape[1] != k.joints) {
        PyErr_SetString(PyExc_ValueError, "chain_poses: values and terms differ in joints");
        return NULL;
    }
    npy_intp count = values.shape[0], g = geometry.shape[0];
    npy_intp dims[4] = {count, g, 4, 4};
    PyArrayObject *out = cp_new(4, dims, NPY_FLOAT64);
    if (!out)
        return NULL;
    PoseScratch scratch;
    if (!pose_scratch(&scratch, k.joints)) {
        Py_DECREF(out);
        return PyErr_NoMemory();
    }
    double *o = PyArray_DATA(out);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp c = 0; c < count; c++)
        chain_poses_one(&k, F64(values) + c * k.joints, F64(base), I64(geometry), g,
                        scratch.pose, o + 16 * g * c);
    Py_END_ALLOW_THREADS
    pose_scratch_free(&scratch);
    return (PyObject *)out;
}

/* joint_values(q (C, A), limits, actuated, mimics, mimic_terms, out (C, J)) -> -1 or the
 * flat index of the first value outside its limits (rows before it are written). */
KERNEL(joint_values)
{
    CP_NARGS(6);
    IN_F64(0, q, 2);
    Actuators a;
    if (!actuators_of(args, 1, &a, "joint_values"))
        return NULL;
    OUT_F64(5, out, 2);
    if (q.shape[1] != a.actuators || out.shape[0] != q.shape[0]) {
        PyErr_SetString(PyExc_ValueError, "joint_values: shapes differ");
        return NULL;
    }
    npy_intp joints = out.shape[1];
    int64_t bad = -1;
    for (npy_intp c = 0; c < q.shape[0] && bad < 0; c++)
        bad = joint_row(&a, F64(q) + c * a.actuators, c, joints, F64(out) + c * joints);
    return PyLong_FromLongLong(bad);
}

/* place_links(q (1, A), limits, actuated, mimics, mimic_terms, terms, kinds, links, base,
 * geometry (G,), poses (N, 4, 4), versions (N,), start): one configuration validated and
 * posed into a scene, link geometry[g] into poses[start + g], versions[start + g] + 1.
 * -1, or (as joint_values) the index of the first value outside its limits, and then
 * nothing is written. A scene's set_joints per state: one call. */
KERNEL(place_links)
{
    CP_NARGS(13);
    IN_F64(0, q, 2);
    Actuators a;
    if (!actuators_of(args, 1, &a, "place_links"))
        return NULL;
    Joints k;
    if (!joints_of(args, 5, &k, "place_links"))
        return NULL;
    IN_F64(8, base, 2);
    IN_I64(9, geometry, 1);
    OUT_F64(10, poses, 3);
    OUT_I64(11, versions, 1);
    IN_LONG(12, start);
    npy_intp g = geometry.shape[0];
    if (q.shape[0] != 1 || q.shape[1] != a.actuators || start < 0 ||
        start + g > poses.shape[0] || start + g > versions.shape[0]) {
        PyErr_SetString(PyExc_ValueError, "place_links: shapes differ");
        return NULL;
    }
    PoseScratch scratch;
    double values_stack[POSE_STACK];
    double *values = k.joints <= POSE_STACK ? values_stack
                                            : PyMem_RawMalloc(k.joints * sizeof(double));
    if (!values || !pose_scratch(&scratch, k.joints)) {
        if (values != values_stack)
            PyMem_RawFree(values);
        return PyErr_NoMemory();
    }
    int64_t bad = joint_row(&a, F64(q), 0, k.joints, values);
    if (bad < 0) {
        chain_poses_one(&k, values, F64(base), I64(geometry), g, scratch.pose,
                        F64(poses) + 16 * start);
        for (npy_intp i = 0; i < g; i++)
            I64(versions)[start + i]++;
    }
    pose_scratch_free(&scratch);
    if (values != values_stack)
        PyMem_RawFree(values);
    return PyLong_FromLongLong(bad);
}

static PyMethodDef kinematics_methods[] = {
    ENTRY(chain_poses, "(values (C, J), terms, kinds, links, base, geometry (G,)) -> "
                       "(C, G, 4, 4) world poses"),
    ENTRY(joint_values, "(q (C, A), limits, actuated, mimics, mimic_terms, out (C, J)) -> "
                        "-1 or the flat index of the first value outside its limits"),
    ENTRY(place_links, "(q (1, A), limits, actuated, mimics, mimic_terms, terms, kinds, "
                       "links, base, geometry, poses, versions, start) -> -1 or bad index"),
    END_ENTRIES};
