/* Where points are relative to a safety pipe (cadpipe.collision.fixture.locate): a walk
 * per point of the perfect binary tree of boxes over the centreline's units
 * (fixture.SegmentTree: heap order from node 0, children 2k + 1 and 2k + 2), nearer
 * child first. A node is skipped when its box is farther than the best centreline
 * distance and, less its largest radius, than the best wall distance, so both answers
 * are the exact minima over every unit. */
#include "native.h"

/* Distance from point ``p`` (3) to the box ``lo``, ``hi`` (3 each; 0 inside). Each axis's
 * offset is clamped at ``p[r] - p[r]``, which is 0 (+0) for a finite coordinate and NaN
 * otherwise, where the offset is NaN or infinite and the clamp keeps it as 0 would: the
 * same value, but not a constant, so gcc clamps by maxsd instead of a branch per axis,
 * mispredicted in most box tests (11% of locate's time). */
static inline double box_gap(const double *p, const double *lo, const double *hi)
{
    double total = 0.0;
    for (int r = 0; r < 3; r++) {
        double out = cp_max(cp_max(lo[r] - p[r], p[r] - hi[r]), p[r] - p[r]);
        total += out * out;
    }
    return sqrt(total);
}

/* round_cone_at, called (not inlined) from the walk: a pipe of one radius never needs it,
 * and inlined it cost that walk registers (4% of locate's time). */
static __attribute__((noinline)) double wall_at(const double *p, const double *a,
                                                const double *b, double ra, double rb)
{
    return round_cone_at(p, a, b, ra, rb);
}

/* The centreline of fixture._Centreline and its tree. */
typedef struct {
    const double *a, *b, *ra, *rb, *length, *start_arc, *tangent, *lo, *hi, *reach;
    const int64_t *unit;
    npy_intp units;
    int64_t depth;
    int uniform;
    double radius;
} Centreline;

/* Outputs of one point (PipeLocation's arrays). */
typedef struct {
    npy_bool *inside;
    double *sd, *nearest, *arc, *tan;
    int64_t *segment;
} Located;

/* locate's walk for point k. */
static void locate_one(const Centreline *c, const double *p, npy_intp k, Located *out)
{
    int64_t leaves = ((int64_t)1 << c->depth) - 1;   /* the first leaf's node */
    int64_t stack[130];
    double gaps[130];
    double best_line = INFINITY, best_wall = INFINITY, best_t = 0.0;
    int64_t best_unit = -1;
    stack[0] = 0, gaps[0] = box_gap(p, c->lo, c->hi);
    int top = 1;
    while (top) {
        top--;
        int64_t node = stack[top];
        double gap = gaps[top];
        if (gap > best_line && gap - c->reach[node] > best_wall)
            continue;
        if (node >= leaves) {
            int64_t u = c->unit[node - leaves];
            if (u < 0)
                continue;
            const double *a = c->a + 3 * u, *b = c->b + 3 * u;
            double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
            double rx = p[0] - a[0], ry = p[1] - a[1], rz = p[2] - a[2];
            double sq = c->length[u] * c->length[u];
            double t = cp_min(cp_max((rx * ux + ry * uy + rz * uz) / (sq > 0 ? sq : 1.0), 0.0),
                              1.0);
            double dx = rx - t * ux, dy = ry - t * uy, dz = rz - t * uz;
            double d = sqrt(dx * dx + dy * dy + dz * dz);
            if (d < best_line || (d == best_line && u < best_unit))
                best_line = d, best_unit = u, best_t = t;
            double wall = c->uniform ? d - c->radius
                                     : wall_at(p, a, b, c->ra[u], c->rb[u]);
            best_wall = cp_min(best_wall, wall);
            continue;
        }
        int64_t near = 2 * node + 1, far = 2 * node + 2;
        double g_near = box_gap(p, c->lo + 3 * near, c->hi + 3 * near);
        double g_far = box_gap(p, c->lo + 3 * far, c->hi + 3 * far);
        if (g_far < g_near) {
            int64_t n = near;
            double g = g_near;
            near = far, far = n, g_near = g_far, g_far = g;
        }
        stack[top] = far, gaps[top] = g_far;
        stack[top + 1] = near, gaps[top + 1] = g_near;
        top += 2;
    }
    int64_t u = best_unit;
    if (u < 0)               /* no unit nearer than NaN (a NaN point): the last one */
        u += c->units;
    double t = best_t;
    out->sd[k] = best_wall;
    out->inside[k] = best_wall <= 0;
    out->segment[k] = best_unit;
    out->arc[k] = c->start_arc[u] + t * c->length[u];
    for (int r = 0; r < 3; r++) {
        out->nearest[3 * k + r] = c->a[3 * u + r] + t * (c->b[3 * u + r] - c->a[3 * u + r]);
        out->tan[3 * k + r] = c->tangent[3 * u + r];
    }
}

/* locate(points (M, 3), a, b (U, 3), ra, rb, length, start_arc (U,), tangent (U, 3), lo,
 * hi (nodes, 3), reach (nodes,), unit (leaves,), depth, uniform, radius, inside (M,) bool,
 * sd (M,), nearest (M, 3), arc (M,), tan (M, 3), segment (M,) int64) */
KERNEL(locate)
{
    CP_NARGS(21);
    IN_F64(0, points, 2);
    IN_F64(1, a, 2);
    IN_F64(2, b, 2);
    IN_F64(3, ra, 1);
    IN_F64(4, rb, 1);
    IN_F64(5, length, 1);
    IN_F64(6, start_arc, 1);
    IN_F64(7, tangent, 2);
    IN_F64(8, lo, 2);
    IN_F64(9, hi, 2);
    IN_F64(10, reach, 1);
    IN_I64(11, unit, 1);
    IN_LONG(12, depth);
    IN_FLAG(13, uniform);
    IN_DOUBLE(14, radius);
    OUT_BOOL(15, inside, 1);
    OUT_F64(16, sd, 1);
    OUT_F64(17, nearest, 2);
    OUT_F64(18, arc, 1);
    OUT_F64(19, tan, 2);
    OUT_I64(20, segment, 1);
    npy_intp m = points.shape[0], units = a.shape[0];
    if (depth < 0 || depth > 62 || unit.shape[0] != ((npy_intp)1 << depth) ||
        lo.shape[0] != 2 * unit.shape[0] - 1 || hi.shape[0] != lo.shape[0] ||
        reach.shape[0] != lo.shape[0] || units < 1 || inside.shape[0] != m ||
        sd.shape[0] != m || nearest.shape[0] != m || arc.shape[0] != m ||
        tan.shape[0] != m || segment.shape[0] != m) {
        PyErr_SetString(PyExc_ValueError, "locate: shapes differ");
        return NULL;
    }
    Centreline c = {F64(a), F64(b), F64(ra), F64(rb), F64(length), F64(start_arc),
                    F64(tangent), F64(lo), F64(hi), F64(reach), I64(unit), units, depth,
                    uniform, radius};
    Located out = {BOOL(inside), F64(sd), F64(nearest), F64(arc), F64(tan), I64(segment)};
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp k = 0; k < m; k++)
        locate_one(&c, F64(points) + 3 * k, k, &out);
    Py_END_ALLOW_THREADS
    Py_RETURN_NONE;
}

static PyMethodDef fixture_methods[] = {
    ENTRY(locate, "(points, a, b, ra, rb, length, start_arc, tangent, lo, hi, reach, unit, "
                  "depth, uniform, radius, inside, sd, nearest, arc, tan, segment): "
                  "fixture.locate's walk"),
    END_ENTRIES};
