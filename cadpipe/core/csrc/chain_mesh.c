/* A chain's capsule tree walked against a mesh's triangle tree: the least capsule-triangle
 * gap per pose (cadpipe.collision.chain_mesh explains the trees, the bounds and the order).
 * Needs hierarchy.c (the tree check, TREE_DEPTH_MAX) before it. */
#include "native.h"
#include "distance.h"

/* relative rounding slack of the walk's bounds (of the coordinates they come from) */
#define MESH_SLACK 1e-12
#define MESH_STACK (4 * (2 * TREE_DEPTH_MAX + 2))
/* a chain's placed nodes go on the C stack up to this many (else malloc) */
#define MESH_NODES_LOCAL 320

/* Squared distance between the box ``lo`` ``hi`` of mesh node ``box`` (a row of boxes: lo,
 * hi, size) and the box ``lo``, ``hi`` (3 each). */
static inline double box_gap_sq(const double *box, const double *lo, const double *hi)
{
    double total = 0.0;
    for (int r = 0; r < 3; r++) {
        double out = cp_max(cp_max(box[r] - hi[r], lo[r] - box[3 + r]), 0.0);
        total += out * out;
    }
    return total;
}

/* Chain node ``c`` at pose ``m``: its chord's ends moved into ``placed[0:6]``, their box
 * widened by the outer radius into ``placed[6:12]`` (lo, hi), its size (the sum of its
 * extents) into ``placed[12]``. */
static inline void place_node(const double *m, const double *points, const double *row,
                              const int64_t *ends, double *placed)
{
    double outer = row[9];
    for (int e = 0; e < 2; e++) {
        const double *p = points + 3 * ends[e];
        for (int r = 0; r < 3; r++)
            placed[3 * e + r] = m[4 * r] * p[0] + m[4 * r + 1] * p[1] + m[4 * r + 2] * p[2] +
                                m[4 * r + 3];
    }
    for (int r = 0; r < 3; r++) {
        double x = placed[r], y = placed[3 + r];
        placed[6 + r] = cp_min(x, y) - outer;
        placed[9 + r] = cp_max(x, y) + outer;
    }
    placed[12] = placed[9] - placed[6] + placed[10] - placed[7] + placed[11] - placed[8];
}

/* A lower bound of the gap between the oriented box ``f`` (a frames row: centre, axes as
 * rows, half extents) and the capsule of ``chord`` (6) and ``radius``: the largest gap of
 * their projections on the box's axes, less rounding slack. */
static inline double oriented_gap(const double *f, const double *chord, double radius)
{
    double px = chord[0] - f[0], py = chord[1] - f[1], pz = chord[2] - f[2];
    double qx = chord[3] - f[0], qy = chord[4] - f[1], qz = chord[5] - f[2];
    double slack = MESH_SLACK * (fabs(px) + fabs(py) + fabs(pz) + fabs(qx) + fabs(qy) + fabs(qz));
    double bound = -INFINITY;
    for (int r = 0; r < 3; r++) {
        const double *axis = f + 3 + 3 * r;
        double a = axis[0] * px + axis[1] * py + axis[2] * pz;
        double b = axis[0] * qx + axis[1] * qy + axis[2] * qz;
        double half = f[12 + r];
        bound = cp_max(cp_max(bound, cp_min(a, b) - half), -half - cp_max(a, b));
    }
    return bound - radius - slack;
}

/* How far the chord (6) stays from the oriented box ``f``'s middle plane across its
 * thinnest axis, -1 where it crosses it: a yes/no walk takes the smaller first. */
static inline double crossing(const double *f, const double *chord)
{
    double a = f[3] * (chord[0] - f[0]) + f[4] * (chord[1] - f[1]) + f[5] * (chord[2] - f[2]);
    double b = f[3] * (chord[3] - f[0]) + f[4] * (chord[4] - f[1]) + f[5] * (chord[5] - f[2]);
    return a * b <= 0.0 ? -1.0 : cp_min(fabs(a), fabs(b));
}

/* A lower bound of the gap between triangle ``t`` (9) and the capsule of ``chord`` (6) and
 * ``radius``: how far both ends lie on one side of the triangle's plane (-inf where they do
 * not), less the radius and rounding slack (of the plane's and the ends' coordinates: a
 * sliver's normal is rounded the most). */
static inline double plane_gap(const double *t, const double *chord, double radius)
{
    double e1x = t[3] - t[0], e1y = t[4] - t[1], e1z = t[5] - t[2];
    double e2x = t[6] - t[0], e2y = t[7] - t[1], e2z = t[8] - t[2];
    double nx = e1y * e2z - e1z * e2y, ny = e1z * e2x - e1x * e2z, nz = e1x * e2y - e1y * e2x;
    double ax = chord[0] - t[0], ay = chord[1] - t[1], az = chord[2] - t[2];
    double bx = chord[3] - t[0], by = chord[4] - t[1], bz = chord[5] - t[2];
    double da = nx * ax + ny * ay + nz * az;
    double db = nx * bx + ny * by + nz * bz;
    if (!((da > 0.0 && db > 0.0) || (da < 0.0 && db < 0.0)))
        return -INFINITY;
    double length = sqrt(nx * nx + ny * ny + nz * nz);
    double slack = MESH_SLACK * (fabs(e1x) + fabs(e1y) + fabs(e1z)) *
                   (fabs(e2x) + fabs(e2y) + fabs(e2z)) *
                   (fabs(ax) + fabs(ay) + fabs(az) + fabs(bx) + fabs(by) + fabs(bz));
    return (cp_min(fabs(da), fabs(db)) - slack) / length - radius;
}

/* The walk of chain_mesh.walk for ``count`` poses (4, 4) of the chain in the mesh's frame:
 * the mesh's tree ``boxes`` (nodes, 7), ``frames`` (inner nodes, 15), ``triangles``
 * (leaves, 9) of ``depth_m``; the chain's ``table`` (``nodes_c``, 10), ``index``
 * (``nodes_c``, 3), ``points`` (K, 3) of ``depth_c``. Per pose the least gap, its unit
 * and closest points (``near`` on the unit's axis, ``far`` on the triangle, 3 each; left
 * as they were where no leaf pair was tested); with ``yes_no`` a pose stops at its first
 * gap <= 0. Returns 0, or -2 when there is no memory. */
static int mesh_walk(const double *boxes, const double *frames, const double *triangles,
                     int64_t depth_m, const double *table, const int64_t *index,
                     const double *points, npy_intp nodes_c, int64_t depth_c, const double *poses,
                     npy_intp count, int yes_no, double *gap, int64_t *unit, double *near,
                     double *far)
{
    int64_t leaves_m = ((int64_t)1 << depth_m) - 1, leaves_c = ((int64_t)1 << depth_c) - 1;
    /* each chain node's chord ends, box and size (place_node), and the pose it was placed at */
    double local[13 * MESH_NODES_LOCAL];
    int64_t local_at[MESH_NODES_LOCAL];
    double *placed = local;
    int64_t *placed_at = local_at;
    if (nodes_c > MESH_NODES_LOCAL) {
        placed = malloc(sizeof(double) * 13 * nodes_c);
        placed_at = malloc(sizeof(int64_t) * nodes_c);
        if (!placed || !placed_at) {
            free(placed);
            free(placed_at);
            return -2;
        }
    }
    for (npy_intp c = 0; c < nodes_c; c++)
        placed_at[c] = -1;
    int64_t stack_m[MESH_STACK], stack_c[MESH_STACK];
    double stack_gap[MESH_STACK];
    for (npy_intp p = 0; p < count; p++) {
        const double *m = poses + 16 * p;
        place_node(m, points, table, index, placed);
        placed_at[0] = p;
        double best = INFINITY;
        unit[p] = -1;
        stack_m[0] = 0, stack_c[0] = 0;
        stack_gap[0] = sqrt(box_gap_sq(boxes, placed + 6, placed + 9));
        int top = 1;
        while (top) {
            top--;
            int64_t nm = stack_m[top], nc = stack_c[top];
            double bound = stack_gap[top];
            double radius = table[10 * nc + 9];
            double limit = yes_no ? 0.0 : best;
            if (bound > limit || radius == -INFINITY)
                continue;
            const double *chord = placed + 13 * nc;
            int leaf_m = nm >= leaves_m, leaf_c = nc >= leaves_c;
            if (leaf_m && leaf_c) {
                if (index[3 * nc + 2] < 0)
                    continue;
                const double *tri = triangles + 9 * (nm - leaves_m);
                if (plane_gap(tri, chord, radius) > limit)
                    continue;
                V3 on_axis, on_triangle;
                double d = segment_triangle(v3_at(chord), v3_at(chord + 3), tri, &on_axis,
                                            &on_triangle) - radius;
                if (d < best) {
                    best = d;
                    unit[p] = index[3 * nc + 2];
                    v3_store(near + 3 * p, on_axis);
                    v3_store(far + 3 * p, on_triangle);
                }
                if (yes_no && best <= 0)
                    break;
                continue;
            }
            if ((leaf_m ? plane_gap(triangles + 9 * (nm - leaves_m), chord, radius)
                        : oriented_gap(frames + 15 * nm, chord, radius)) > limit)
                continue;
            /* split the chain node when the mesh node is a leaf or the smaller box */
            int64_t m0, m1, c0, c1;
            if (!leaf_c && (leaf_m || chord[12] >= boxes[7 * nm + 6])) {
                m0 = nm, m1 = nm, c0 = 2 * nc + 1, c1 = 2 * nc + 2;
                for (int64_t c = c0; c <= c1; c++)
                    if (placed_at[c] != p) {
                        place_node(m, points, table + 10 * c, index + 3 * c, placed + 13 * c);
                        placed_at[c] = p;
                    }
            } else {
                m0 = 2 * nm + 1, m1 = 2 * nm + 2, c0 = nc, c1 = nc;
            }
            const double *p0 = placed + 13 * c0, *p1 = placed + 13 * c1;
            double g0 = box_gap_sq(boxes + 7 * m0, p0 + 6, p0 + 9);
            double g1 = box_gap_sq(boxes + 7 * m1, p1 + 6, p1 + 9);
            if (yes_no) {
                /* only touching boxes can lead to a contact: the others would be dropped
                 * when taken, so they are not stacked (the same visits, fewer steps) */
                if (g0 == 0.0 && g1 == 0.0 &&
                    (m0 >= leaves_m ? plane_gap(triangles + 9 * (m1 - leaves_m), p1, 0.0) <
                                          plane_gap(triangles + 9 * (m0 - leaves_m), p0, 0.0)
                                    : crossing(frames + 15 * m1, p1) <
                                          crossing(frames + 15 * m0, p0))) {
                    int64_t swap = m0;
                    m0 = m1, m1 = swap, swap = c0, c0 = c1, c1 = swap;
                }
                if (g1 == 0.0) {
                    stack_m[top] = m1, stack_c[top] = c1, stack_gap[top] = 0.0;
                    top++;
                }
                if (g0 == 0.0) {
                    stack_m[top] = m0, stack_c[top] = c0, stack_gap[top] = 0.0;
                    top++;
                }
                continue;
            }
            g0 = sqrt(g0), g1 = sqrt(g1);
            if (g1 < g0) {
                int64_t swap = m0;
                m0 = m1, m1 = swap, swap = c0, c0 = c1, c1 = swap;
                double g = g0;
                g0 = g1, g1 = g;
            }
            stack_m[top] = m1, stack_c[top] = c1, stack_gap[top] = g1;
            stack_m[top + 1] = m0, stack_c[top + 1] = c0, stack_gap[top + 1] = g0;
            top += 2;
        }
        gap[p] = best;
    }
    if (placed != local) {
        free(placed);
        free(placed_at);
    }
    return 0;
}

/* Whether ``boxes``, ``frames`` and ``triangles`` are a triangle tree of ``depth``
 * (chain_mesh.TriangleTree); a ValueError naming ``kernel`` otherwise. */
static int mesh_tree_ok(const Arr *boxes, const Arr *frames, const Arr *triangles, int64_t depth,
                        const char *kernel)
{
    if (depth < 0 || depth > TREE_DEPTH_MAX || boxes->shape[1] != 7 || frames->shape[1] != 15 ||
        triangles->shape[1] != 9 || triangles->shape[0] != (npy_intp)1 << depth ||
        frames->shape[0] != triangles->shape[0] - 1 ||
        boxes->shape[0] != 2 * triangles->shape[0] - 1) {
        PyErr_Format(PyExc_ValueError, "%s: not a triangle tree of depth %lld", kernel,
                     (long long)depth);
        return 0;
    }
    return 1;
}

/* mesh_walk(boxes, frames, triangles, depth_m, table, index, points, depth_c, poses (P, 4, 4),
 * yes_no, gap (P,), unit (P,), near (P, 3), far (P, 3)) (cadpipe.collision.chain_mesh.walk) */
KERNEL(mesh_walk)
{
    CP_NARGS(14);
    IN_F64(0, boxes, 2);
    IN_F64(1, frames, 2);
    IN_F64(2, triangles, 2);
    IN_LONG(3, depth_m);
    IN_F64(4, table, 2);
    IN_I64(5, index, 2);
    IN_F64(6, points, 2);
    IN_LONG(7, depth_c);
    IN_F64(8, poses, 3);
    IN_FLAG(9, yes_no);
    OUT_F64(10, gap, 1);
    OUT_I64(11, unit, 1);
    OUT_F64(12, near, 2);
    OUT_F64(13, far, 2);
    npy_intp count = poses.shape[0];
    if (!mesh_tree_ok(&boxes, &frames, &triangles, depth_m, "mesh_walk") ||
        !chain_tree_ok(&table, &index, depth_c, points.shape[0], "mesh_walk"))
        return NULL;
    if (points.shape[1] != 3 || poses.shape[1] != 4 || poses.shape[2] != 4 ||
        gap.shape[0] != count || unit.shape[0] != count || near.shape[0] != count ||
        near.shape[1] != 3 || far.shape[0] != count || far.shape[1] != 3) {
        PyErr_SetString(PyExc_ValueError, "mesh_walk: shapes differ");
        return NULL;
    }
    int status;
    Py_BEGIN_ALLOW_THREADS
    status = mesh_walk(F64(boxes), F64(frames), F64(triangles), depth_m, F64(table), I64(index),
                       F64(points), table.shape[0], depth_c, F64(poses), count, yes_no, F64(gap),
                       I64(unit), F64(near), F64(far));
    Py_END_ALLOW_THREADS
    if (status)
        return PyErr_NoMemory();
    Py_RETURN_NONE;
}

/* segment_triangle(a (3,), b (3,), t (9,), near (3,), far (3,)) -> distance: distance.h's,
 * the closest points written to near (on the segment) and far (on the triangle) */
KERNEL(segment_triangle)
{
    CP_NARGS(5);
    IN_F64(0, a, 1);
    IN_F64(1, b, 1);
    IN_F64(2, t, 1);
    OUT_F64(3, near, 1);
    OUT_F64(4, far, 1);
    if (a.size != 3 || b.size != 3 || t.size != 9 || near.size != 3 || far.size != 3) {
        PyErr_SetString(PyExc_ValueError, "segment_triangle: shapes differ");
        return NULL;
    }
    V3 p, q;
    double d = segment_triangle(v3_at(F64(a)), v3_at(F64(b)), F64(t), &p, &q);
    v3_store(F64(near), p);
    v3_store(F64(far), q);
    return PyFloat_FromDouble(d);
}

static PyMethodDef chain_mesh_methods[] = {
    ENTRY(mesh_walk, "(boxes, frames, triangles, depth_m, table, index, points, depth_c, poses,"
                     " yes_no, gap, unit, near, far): a capsule tree against a triangle tree"),
    ENTRY(segment_triangle, "(a, b, t, near, far) -> distance of a segment and a triangle"),
    END_ENTRIES};
