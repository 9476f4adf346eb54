/* Conservative advancement of a robot's motion, pair by pair (cadpipe.collision.motion
 * explains the speed bounds and the advancement).
 *
 * One call advances every pair over one segment of the motion, forward kinematics
 * (kinematics.c) and the clearance bounds (convex.c's GJK) included; it returns to
 * Python only for an exact clearance. */
#include "native.h"

/* what advance comes back with (motion._FREE, ...) */
enum { MOTION_FREE = 0, MOTION_CONTACT = 1, MOTION_ASK = 2, MOTION_REFUSED = 3,
       MOTION_GRAZING = 4 };

/* The robot's chain facts (motion._chain): per frame (F) its link's box corners (8, 3)
 * and radius, ``above`` (F, J), ``below`` (F, J, J); per joint (J) whether it turns or
 * slides, its origin offset length, parent frame, origin (4, 4) and axis (3). */
typedef struct {
    const int64_t *link_frames, *parent;
    const double *corners, *radius, *offset, *origin, *axis;
    const npy_bool *above, *below, *turning, *sliding;
    npy_intp links, frames, joints;
} Chain;

/* The robot's kinematics (motion._kinematics and the base): its joints, the frames to
 * pose (F,) and the base pose (4, 4). */
typedef struct {
    Joints joints;
    const int64_t *frame_index;
    const double *base;
    npy_intp frames;
} Kinematics;

/* The pairs a motion can change (motion._Setup.pairs): frames a, b (-1: a standing
 * object), objects, the standing pose (P, 4, 4), whether both bodies are their pieces,
 * and every object's oriented box corners (N * 8, 3). */
typedef struct {
    const int64_t *a_of, *b_of, *object_a, *object_b;
    const double *standing, *boxes;
    const npy_bool *exact;
    npy_intp count, box_points;
} Pairs;

/* The items of tuple ``o`` as arrays of the given types and dimensions, into ``out``. */
static int tuple_arrays(PyObject *o, int n, const int *types, const int *dims, Arr *out,
                        const char *kernel, int index)
{
    if (!PyTuple_Check(o) || PyTuple_GET_SIZE(o) != n) {
        PyErr_Format(PyExc_TypeError, "cadpipe kernel %s, argument %d: need a tuple of %d "
                     "arrays", kernel, index, n);
        return 0;
    }
    for (int k = 0; k < n; k++)
        if (!cp_array(PyTuple_GET_ITEM(o, k), types[k], dims[k], 0, &out[k], kernel, index))
            return 0;
    return 1;
}

static int chain_of(PyObject *o, Chain *c, const char *kernel, int index)
{
    static const int types[11] = {NPY_INT64, NPY_FLOAT64, NPY_FLOAT64, NPY_BOOL, NPY_BOOL,
                                  NPY_BOOL, NPY_BOOL, NPY_FLOAT64, NPY_INT64, NPY_FLOAT64,
                                  NPY_FLOAT64};
    static const int dims[11] = {1, 3, 1, 2, 3, 1, 1, 1, 1, 3, 2};
    Arr a[11];
    if (!tuple_arrays(o, 11, types, dims, a, kernel, index))
        return 0;
    c->link_frames = I64(a[0]), c->corners = F64(a[1]), c->radius = F64(a[2]);
    c->above = BOOL(a[3]), c->below = BOOL(a[4]), c->turning = BOOL(a[5]);
    c->sliding = BOOL(a[6]), c->offset = F64(a[7]), c->parent = I64(a[8]);
    c->origin = F64(a[9]), c->axis = F64(a[10]);
    c->links = a[0].shape[0], c->frames = a[3].shape[0], c->joints = a[3].shape[1];
    for (int k = 5; k < 11; k++)
        if (a[k].shape[0] != c->joints) {
            PyErr_Format(PyExc_ValueError, "cadpipe kernel %s: the chain's per-joint arrays "
                         "differ in joints", kernel);
            return 0;
        }
    return 1;
}

static int kinematics_of(PyObject *o, Kinematics *k, const char *kernel, int index)
{
    static const int types[5] = {NPY_FLOAT64, NPY_FLOAT64, NPY_INT64, NPY_INT64, NPY_FLOAT64};
    static const int dims[5] = {4, 2, 2, 1, 2};
    Arr a[5];
    if (!tuple_arrays(o, 5, types, dims, a, kernel, index))
        return 0;
    k->joints.terms = F64(a[0]), k->joints.kinds = F64(a[1]), k->joints.links = I64(a[2]);
    k->joints.joints = a[0].shape[0];
    k->frame_index = I64(a[3]), k->frames = a[3].shape[0], k->base = F64(a[4]);
    return 1;
}

static int pairs_of(PyObject *o, Pairs *p, const char *kernel, int index)
{
    static const int types[7] = {NPY_INT64, NPY_INT64, NPY_INT64, NPY_INT64, NPY_FLOAT64,
                                 NPY_BOOL, NPY_FLOAT64};
    static const int dims[7] = {1, 1, 1, 1, 3, 1, 2};
    Arr a[7];
    if (!tuple_arrays(o, 7, types, dims, a, kernel, index))
        return 0;
    p->a_of = I64(a[0]), p->b_of = I64(a[1]), p->object_a = I64(a[2]);
    p->object_b = I64(a[3]), p->standing = F64(a[4]), p->exact = BOOL(a[5]);
    p->boxes = F64(a[6]), p->count = a[0].shape[0], p->box_points = a[6].shape[0];
    return 1;
}

/* Per segment v_a -> v_b: ``lever`` (F, J), the chain bound of the distance of each
 * frame's link from each turning joint's origin above it (1 for a sliding joint, 0 off
 * its path), and ``relative`` (F, J), how fast the joints below j can move the link
 * relative to j (the chain bounds times the joint steps). */
static void chain_levers(const Chain *c, const double *v_a, const double *v_b, double *lever,
                         double *relative)
{
    npy_intp nf = c->frames, nj = c->joints;
    for (npy_intp f = 0; f < nf; f++) {
        double *lv = lever + f * nj, *rel = relative + f * nj;
        const npy_bool *below = c->below + f * nj * nj;
        for (npy_intp j = 0; j < nj; j++) {
            lv[j] = 0.0, rel[j] = 0.0;
            if (!c->above[f * nj + j])
                continue;
            if (c->sliding[j])
                lv[j] = 1.0;
            else if (c->turning[j]) {
                double reach = c->radius[f];
                for (npy_intp k = 0; k < nj; k++)
                    if (below[j * nj + k]) {
                        reach += c->offset[k];
                        if (c->sliding[k])
                            reach += cp_max(fabs(v_a[k]), fabs(v_b[k]));
                    }
                lv[j] = reach;
            }
        }
        for (npy_intp j = 0; j < nj; j++)
            for (npy_intp k = 0; k < nj; k++)
                if (below[j * nj + k])
                    rel[j] += lv[k] * fabs(v_b[k] - v_a[k]);
    }
}

/* ``(D, S, A)`` into ``out`` (3) of the link of frame ``link`` over the ``remaining``
 * part of the segment, ``frames`` (F, 4, 4) where every frame stands now, leaving out
 * the joints above frame ``other`` too (-1: none): the speed bound D (step 1 of the
 * motion module's docstring), the greatest speed S of the link's box now, and a bound A
 * of how fast any point's speed can grow (see closing). ``reach`` (J,) is scratch.
 *
 * With the joints' rates dq_j (per unit of t), axes u_j and origins o_j, a point p of
 * the link moves at sum_j dq_j u_j x (p - o_j) (turning) plus dq_j u_j (sliding): a
 * rigid velocity field, greatest at a corner of the link's box. Its rate of change is
 * at most sum_j |dq_j| (2 w_j R_j + sum_(k >= j) |dq_k| r_k), w_j the rates of the
 * turning joints above j (how fast u_j turns), R_j the chain bound of |p - o_j| and
 * r_k the lever of D (1 for a sliding joint). */
static void link_motion(const Chain *c, const double *lever, const double *relative,
                        const double *v_a, const double *v_b, const double *frames,
                        int64_t link, int64_t other, double remaining, double *reach,
                        double *out)
{
    npy_intp nj = c->joints;
    const double *pose = frames + 16 * link, *corners = c->corners + 24 * link;
    const npy_bool *above = c->above + link * nj, *below = c->below + link * nj * nj;
    const double *lv = lever + link * nj, *rel = relative + link * nj;
    double box[8][3];
    for (int k = 0; k < 8; k++)
        for (int r = 0; r < 3; r++)
            box[k][r] = pose[4 * r] * corners[3 * k] + pose[4 * r + 1] * corners[3 * k + 1] +
                        pose[4 * r + 2] * corners[3 * k + 2] + pose[4 * r + 3];
    /* the velocity field p -> spin x p + shift; reach[j] is r_j over the rest of the segment */
    double sx = 0.0, sy = 0.0, sz = 0.0, hx = 0.0, hy = 0.0, hz = 0.0, speed = 0.0;
    for (npy_intp j = 0; j < nj; j++) {
        double rate = v_b[j] - v_a[j];
        reach[j] = 0.0;
        if (!above[j] || rate == 0.0 || (other >= 0 && c->above[other * nj + j]))
            continue;
        const double *up = frames + 16 * c->parent[j], *o = c->origin + 16 * j;
        const double *ax = c->axis + 3 * j;
        /* the joint's axis where it stands: its origin p and unit direction d */
        double px = up[0] * o[3] + up[1] * o[7] + up[2] * o[11] + up[3];
        double py = up[4] * o[3] + up[5] * o[7] + up[6] * o[11] + up[7];
        double pz = up[8] * o[3] + up[9] * o[7] + up[10] * o[11] + up[11];
        double dx = 0.0, dy = 0.0, dz = 0.0;
        for (int m = 0; m < 3; m++) {
            double local = o[4 * m] * ax[0] + o[4 * m + 1] * ax[1] + o[4 * m + 2] * ax[2];
            dx += up[m] * local;
            dy += up[4 + m] * local;
            dz += up[8 + m] * local;
        }
        if (c->sliding[j]) {
            reach[j] = 1.0;
            hx = hx + rate * dx, hy = hy + rate * dy, hz = hz + rate * dz;
        } else if (c->turning[j]) {
            double far = 0.0;
            for (int k = 0; k < 8; k++) {
                double ex = box[k][0] - px, ey = box[k][1] - py, ez = box[k][2] - pz;
                double along = ex * dx + ey * dy + ez * dz;
                far = cp_max(far, ex * ex + ey * ey + ez * ez - along * along);
            }
            reach[j] = cp_min(lv[j], sqrt(far) + rel[j] * remaining);
            sx = sx + rate * dx, sy = sy + rate * dy, sz = sz + rate * dz;
            /* u x (p - o) = u x p - u x o */
            hx -= rate * (dy * pz - dz * py);
            hy -= rate * (dz * px - dx * pz);
            hz -= rate * (dx * py - dy * px);
        }
        speed += reach[j] * fabs(rate);
    }
    double fastest = 0.0;
    for (int k = 0; k < 8; k++) {
        double x = box[k][0], y = box[k][1], z = box[k][2];
        double vx = sy * z - sz * y + hx, vy = sz * x - sx * z + hy, vz = sx * y - sy * x + hz;
        fastest = cp_max(fastest, vx * vx + vy * vy + vz * vz);
    }
    double growth = 0.0;
    for (npy_intp j = 0; j < nj; j++) {
        if (reach[j] == 0.0)
            continue;
        double step = fabs(v_b[j] - v_a[j]);
        double turns = 0.0, onward = reach[j] * step;
        for (npy_intp k = 0; k < nj; k++) {
            if (reach[k] == 0.0)
                continue;
            if (below[k * nj + j] && c->turning[k])
                turns += fabs(v_b[k] - v_a[k]);
            else if (below[j * nj + k])
                onward += reach[k] * fabs(v_b[k] - v_a[k]);
        }
        growth += c->turning[j] ? step * (2.0 * turns * lv[j] + onward) : step * turns;
    }
    out[0] = speed, out[1] = sqrt(fastest), out[2] = growth;
}

/* How far the pair can go (a fraction of the segment) before it could close
 * ``clearance``: it closes at most min(D s, S s + A s^2 / 2) over s. */
static inline double closing(double speed, double now, double growth, double clearance)
{
    return cp_max(clearance / speed,
                  2.0 * clearance / (now + sqrt(now * now + 2.0 * growth * clearance)));
}

/* Every frame's pose ``frames`` (F, 4, 4) at time ``t`` of the segment; ``values`` (J,)
 * and ``pose`` ((J + 1) * 16) are scratch. */
static void frames_at(const Kinematics *k, const double *v_a, const double *v_b, double t,
                      double *values, double *pose, double *frames)
{
    for (npy_intp j = 0; j < k->joints.joints; j++)
        values[j] = v_a[j] + t * (v_b[j] - v_a[j]);
    chain_poses_one(&k->joints, values, k->base, k->frame_index, k->frames, pose, frames);
}

/* The scratch of one segment's work, one allocation: lever and relative (F, J), values
 * (J), pose ((J + 1) * 16), frames (F, 4, 4), reach (J). */
typedef struct {
    double *block, *lever, *relative, *values, *pose, *frames, *reach;
} Scratch;

static int scratch_new(Scratch *s, const Chain *c, const Kinematics *k, npy_intp extra)
{
    npy_intp nj = k->joints.joints, fj = c->frames * c->joints;
    npy_intp size = 2 * fj + nj + 16 * (nj + 1) + 16 * k->frames + c->joints + extra;
    s->block = PyMem_RawMalloc((size > 0 ? size : 1) * sizeof(double));
    if (!s->block)
        return 0;
    s->lever = s->block, s->relative = s->lever + fj, s->values = s->relative + fj;
    s->pose = s->values + nj, s->frames = s->pose + 16 * (nj + 1);
    s->reach = s->frames + 16 * k->frames;
    return 1;
}

/* Whether the chain's and the kinematics' frames and joints agree with each other and
 * with the joint values (n of them), so that no index reads past an array. */
static int consistent(const Chain *c, const Kinematics *k, npy_intp n, const char *kernel)
{
    if (c->joints != k->joints.joints || n != c->joints || k->frames != c->frames) {
        PyErr_Format(PyExc_ValueError, "cadpipe kernel %s: the chain, the kinematics and "
                     "the joint values differ in joints or frames", kernel);
        return 0;
    }
    return 1;
}

/* ``(D, S, A)`` (K, 3) of the frames ``chosen`` (K,) from time ``t`` of the segment
 * ``v_a`` -> ``v_b``: motion.speed_bounds. */
static void motions(const Kinematics *k, const Chain *c, const double *v_a, const double *v_b,
                    double t, const int64_t *chosen, npy_intp count, Scratch *s, double *out)
{
    chain_levers(c, v_a, v_b, s->lever, s->relative);
    frames_at(k, v_a, v_b, t, s->values, s->pose, s->frames);
    for (npy_intp i = 0; i < count; i++)
        link_motion(c, s->lever, s->relative, v_a, v_b, s->frames, chosen[i], -1, 1.0 - t,
                    s->reach, out + 3 * i);
}

/* motions(kinematics, chain, v_a (J,), v_b (J,), t, chosen (K,)) -> (K, 3) */
KERNEL(motions)
{
    CP_NARGS(6);
    Kinematics k;
    Chain c;
    if (!kinematics_of(args[0], &k, "motions", 0) || !chain_of(args[1], &c, "motions", 1))
        return NULL;
    IN_F64(2, v_a, 1);
    IN_F64(3, v_b, 1);
    IN_DOUBLE(4, t);
    IN_I64(5, chosen, 1);
    if (!consistent(&c, &k, v_a.shape[0], "motions") || v_b.shape[0] != v_a.shape[0])
        return NULL;
    npy_intp dims[2] = {chosen.shape[0], 3};
    PyArrayObject *out = cp_new(2, dims, NPY_FLOAT64);
    Scratch s;
    if (!out || !scratch_new(&s, &c, &k, 0)) {
        Py_XDECREF(out);
        return PyErr_NoMemory();
    }
    motions(&k, &c, F64(v_a), F64(v_b), t, I64(chosen), chosen.shape[0], &s, PyArray_DATA(out));
    PyMem_RawFree(s.block);
    return (PyObject *)out;
}

/* fastest(kinematics, chain, values (C, J), frame) -> (C - 1,): a bound of the speed of
 * ``frame``'s origin all along each segment between rows of ``values`` (the smaller of
 * D and S + A from the segment's start). */
KERNEL(fastest)
{
    CP_NARGS(4);
    Kinematics k;
    Chain c;
    if (!kinematics_of(args[0], &k, "fastest", 0) || !chain_of(args[1], &c, "fastest", 1))
        return NULL;
    IN_F64(2, values, 2);
    IN_LONG(3, frame);
    if (!consistent(&c, &k, values.shape[1], "fastest"))
        return NULL;
    if (values.shape[0] < 1) {
        PyErr_SetString(PyExc_ValueError, "fastest: no configurations");
        return NULL;
    }
    npy_intp dims[1] = {values.shape[0] - 1};
    PyArrayObject *out = cp_new(1, dims, NPY_FLOAT64);
    Scratch s;
    if (!out || !scratch_new(&s, &c, &k, 0)) {
        Py_XDECREF(out);
        return PyErr_NoMemory();
    }
    double *o = PyArray_DATA(out);
    npy_intp nj = values.shape[1];
    for (npy_intp seg = 0; seg < dims[0]; seg++) {
        double m[3];
        motions(&k, &c, F64(values) + seg * nj, F64(values) + (seg + 1) * nj, 0.0, &frame, 1,
                &s, m);
        o[seg] = cp_min(m[0], m[1] + m[2]);
    }
    PyMem_RawFree(s.block);
    return (PyObject *)out;
}

/* Count (and record, while ``times`` (T,) has room) a configuration posed at time ``t``,
 * unless it is the one posed last (a call after MOTION_ASK starts there); ``posed`` is
 * (count, last time). */
static inline void posed_at(double *posed, double *times, npy_intp room, double t)
{
    if (posed[0] > 0 && posed[1] == t)
        return;
    int64_t at = (int64_t)posed[0];
    if (at < room)
        times[at] = t;
    posed[0] = (double)(at + 1), posed[1] = t;
}

/* The advancement of every pair over the segment v_a -> v_b, in time order (see
 * KERNEL(advance)); the code, and the pair and clearance into ``pair``, ``bound``. */
static int advance(const Kinematics *kin, const Chain *c, const Pairs *pr, const Pieces *pc,
                   const double *v_a, const double *v_b, double tolerance, double margin,
                   double *t, double *given, int64_t *steps, double *posed, double *times,
                   npy_intp room, int64_t iterations, int64_t max_steps, Scratch *s,
                   int64_t *pair, double *bound)
{
    npy_intp count = pr->count, nf = c->frames;
    /* the boxes' pads (zeros), each link's motion against standing objects and when */
    double *flat = s->reach + c->joints, *alone = flat + pr->box_points;
    double *alone_at = alone + 3 * nf;
    for (npy_intp f = 0; f < nf; f++)
        alone_at[f] = -1.0;
    chain_levers(c, v_a, v_b, s->lever, s->relative);
    double frames_time = INFINITY;      /* t.min(): the pair furthest behind */
    for (npy_intp p = 0; p < count; p++)
        frames_time = cp_min(frames_time, t[p]);
    frames_at(kin, v_a, v_b, frames_time, s->values, s->pose, s->frames);
    posed_at(posed, times, room, frames_time);
    const double *frames = s->frames;
    for (;;) {
        int64_t k = -1;
        for (npy_intp p = 0; p < count; p++)        /* the pair furthest behind */
            if (t[p] < 1.0 && (k < 0 || t[p] < t[k]))
                k = p;
        if (k < 0) {
            *pair = -1, *bound = 0.0;
            return MOTION_FREE;
        }
        double now = t[k];
        if (now != frames_time) {
            frames_at(kin, v_a, v_b, now, s->values, s->pose, s->frames);
            frames_time = now;
            posed_at(posed, times, room, now);
        }
        int64_t a = pr->a_of[k], b = pr->b_of[k];
        const double *pose_a = frames + 16 * a;
        const double *pose_b = b >= 0 ? frames + 16 * b : pr->standing + 16 * k;
        double remaining = 1.0 - now;
        double speed, fastest, growth;
        if (b >= 0) {
            double one[3], more[3];
            link_motion(c, s->lever, s->relative, v_a, v_b, frames, a, b, remaining, s->reach,
                        one);
            link_motion(c, s->lever, s->relative, v_a, v_b, frames, b, a, remaining, s->reach,
                        more);
            speed = one[0] + more[0], fastest = one[1] + more[1], growth = one[2] + more[2];
        } else {          /* a link against standing objects: one motion for them all */
            if (alone_at[a] != now) {
                link_motion(c, s->lever, s->relative, v_a, v_b, frames, a, -1, remaining,
                            s->reach, alone + 3 * a);
                alone_at[a] = now;
            }
            speed = alone[3 * a], fastest = alone[3 * a + 1], growth = alone[3 * a + 2];
        }
        /* the clearance that proves the rest of the segment (at most D times it) */
        double need = cp_min(speed * remaining, (fastest + 0.5 * growth * remaining) * remaining) +
                      margin;
        double lower, upper;
        int known;
        if (given[k] == given[k]) {
            lower = upper = given[k];
            given[k] = NAN;
            known = 1;
        } else {
            int64_t i = pr->object_a[k], j = pr->object_b[k];
            gjk_bounds(pr->boxes, flat, 8 * i, 8 * i + 8, pose_a, 8 * j, 8 * j + 8, pose_b, need,
                       iterations, &lower, &upper);
            if (lower < need) {    /* the pieces lie inside the boxes: never nearer */
                double hull;
                body_bounds(pc->points, pc->pads, pc->piece_starts, pc->centre, pc->radius,
                            pc->pieces, i, pose_a, j, pose_b, need, iterations, &hull, &upper);
                lower = cp_max(lower, hull);
            }
            known = pr->exact[k];
        }
        if (lower >= need) {
            t[k] = 1.0;
            continue;
        }
        *pair = k;
        steps[k] += 1;
        if (steps[k] > max_steps) {
            *bound = lower;
            return MOTION_GRAZING;
        }
        if (margin > 0.0) {
            if (lower < 2.0 * margin) {
                *bound = lower;
                return MOTION_REFUSED;
            }
            t[k] = cp_min(now + closing(speed, fastest, growth, lower - margin), 1.0);
        } else if (lower >= tolerance || (known && upper >= tolerance && lower > 0.0)) {
            t[k] = cp_min(now + closing(speed, fastest, growth, lower), 1.0);
        } else if (known && upper < tolerance) {
            *bound = upper;
            return MOTION_CONTACT;
        } else {
            *bound = lower;
            return MOTION_ASK;
        }
    }
}

/* advance(kinematics, chain, pairs, pieces, v_a (J,), v_b (J,), tolerance, margin,
 * t (P,), given (P,), steps (P,), posed (2,), times (T,), iterations, max_steps)
 * -> (code, pair, clearance): the conservative advancement of every pair over the
 * segment between full joint values v_a and v_b, in time order (the tuples as
 * motion._Setup holds them, the kinematics with the base pose last).
 *
 * ``t`` is how far each pair is proven free (1: all of it), ``given`` exact clearances
 * the caller supplies for the pairs it was asked about (NaN: none), ``steps`` each
 * pair's advancement steps; all three carry over when the caller comes back after
 * MOTION_ASK. ``posed[0]`` counts the configurations posed (forward kinematics),
 * ``posed[1]`` is the last one's time; the first T times are written into ``times``.
 * Codes: MOTION_FREE; MOTION_CONTACT, MOTION_REFUSED (margin > 0) or MOTION_GRAZING (more
 * than max_steps steps) for the pair at t[pair]; MOTION_ASK, the caller is to put the
 * exact clearance of the pair at t[pair] into ``given`` and call again. GJK runs
 * ``iterations`` steps at most. */
KERNEL(advance)
{
    CP_NARGS(15);
    Kinematics k;
    Chain c;
    Pairs pr;
    Pieces pc;
    if (!kinematics_of(args[0], &k, "advance", 0) || !chain_of(args[1], &c, "advance", 1) ||
        !pairs_of(args[2], &pr, "advance", 2))
        return NULL;
    if (!PyTuple_Check(args[3]) || PyTuple_GET_SIZE(args[3]) != 6) {
        PyErr_SetString(PyExc_TypeError, "cadpipe kernel advance, argument 3: need a tuple "
                                         "of 6 arrays");
        return NULL;
    }
    if (!pieces_of(PySequence_Fast_ITEMS(args[3]), &pc, "advance (pieces)", 0))
        return NULL;
    IN_F64(4, v_a, 1);
    IN_F64(5, v_b, 1);
    IN_DOUBLE(6, tolerance);
    IN_DOUBLE(7, margin);
    OUT_F64(8, t, 1);
    OUT_F64(9, given, 1);
    OUT_I64(10, steps, 1);
    OUT_F64(11, posed, 1);
    OUT_F64(12, times, 1);
    IN_LONG(13, iterations);
    IN_LONG(14, max_steps);
    if (!consistent(&c, &k, v_a.shape[0], "advance"))
        return NULL;
    if (v_b.shape[0] != v_a.shape[0] || t.shape[0] != pr.count ||
        given.shape[0] != pr.count || steps.shape[0] != pr.count || posed.shape[0] != 2) {
        PyErr_SetString(PyExc_ValueError, "advance: shapes differ");
        return NULL;
    }
    int64_t pair = -1;
    double bound = 0.0;
    int code = MOTION_FREE;
    if (pr.count) {         /* no pairs: nothing can touch (and nothing is posed) */
        Scratch s;
        if (!scratch_new(&s, &c, &k, pr.box_points + 4 * c.frames))
            return PyErr_NoMemory();
        memset(s.reach + c.joints, 0, pr.box_points * sizeof(double));
        Py_BEGIN_ALLOW_THREADS
        code = advance(&k, &c, &pr, &pc, F64(v_a), F64(v_b), tolerance, margin, F64(t),
                       F64(given), I64(steps), F64(posed), F64(times), times.shape[0],
                       iterations, max_steps, &s, &pair, &bound);
        Py_END_ALLOW_THREADS
        PyMem_RawFree(s.block);
    }
    return Py_BuildValue("iLd", code, (long long)pair, bound);
}

static PyMethodDef motion_methods[] = {
    ENTRY(motions, "(kinematics, chain, v_a, v_b, t, chosen) -> (K, 3) speed bounds D, S, A"),
    ENTRY(fastest, "(kinematics, chain, values (C, J), frame) -> (C - 1,) origin speed bounds"),
    ENTRY(advance, "(kinematics, chain, pairs, pieces, v_a, v_b, tolerance, margin, t, given,"
                   " steps, posed, times, iterations, max_steps) -> (code, pair, clearance)"),
    END_ENTRIES};
