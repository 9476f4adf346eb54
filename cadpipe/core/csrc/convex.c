/* Clearance bounds between convex pieces, by GJK (cadpipe.collision.convex explains the
 * bounds). A piece is a padded point set: the hull of the balls B(p_i, r_i). */
#include "native.h"
#include "distance.h"

#define GJK_SLACK 1e-10      /* relative rounding slack taken off every bound */
#define GJK_CONVERGED 1e-9   /* the bounds agree to this fraction of the distance */

/* The point of ``points[lo:hi]`` placed by ``m`` (4, 4) furthest along ``d``, placed. */
static inline V3 support(const double *points, int64_t lo, int64_t hi, const double *m, V3 d)
{
    /* the direction turned into the points' frame */
    double ux = m[0] * d.x + m[4] * d.y + m[8] * d.z;
    double uy = m[1] * d.x + m[5] * d.y + m[9] * d.z;
    double uz = m[2] * d.x + m[6] * d.y + m[10] * d.z;
    double best = -INFINITY;
    int64_t at = lo;
    for (int64_t s = lo; s < hi; s++) {
        double v = ux * points[3 * s] + uy * points[3 * s + 1] + uz * points[3 * s + 2];
        if (v > best) {
            best = v;
            at = s;
        }
    }
    double x = points[3 * at], y = points[3 * at + 1], z = points[3 * at + 2];
    return v3(m[0] * x + m[1] * y + m[2] * z + m[3], m[4] * x + m[5] * y + m[6] * z + m[7],
              m[8] * x + m[9] * y + m[10] * z + m[11]);
}

/* Whether the origin lies beyond face i j k of the tetrahedron s, seen from its fourth
 * corner o (true for a flat tetrahedron: every face is then tried). */
static inline int beyond(const V3 *s, int i, int j, int k, int o)
{
    V3 n = v3_cross(v3_sub(s[j], s[i]), v3_sub(s[k], s[i]));
    double origin = -v3_dot(n, s[i]);
    double corner = v3_dot(n, v3_sub(s[o], s[i]));
    return origin * corner <= 0.0;
}

/* Keep the simplex points ``corners[b]`` whose bit b is set in ``mask``, in order, at
 * the front of ``s``; their count. */
static inline int keep(V3 *s, int n, const int *corners, int mask)
{
    V3 kept[4];
    int count = 0;
    for (int b = 0; b < n; b++)
        if (mask & (1 << b))
            kept[count++] = s[corners[b]];
    for (int r = 0; r < count; r++)
        s[r] = kept[r];
    return count;
}

/* Reduce the simplex s[:n] to the corners spanning its point nearest the origin, which
 * goes to ``v``; the count, 4 (and the origin) when it encloses it. */
static inline int reduce(V3 *s, int n, V3 *v)
{
    int corners[4] = {0, 1, 2, 3}, mask;
    if (n == 1) {
        *v = s[0];
        return 1;
    }
    if (n == 2) {
        *v = nearest_on_segment(s[0], s[1], &mask);
        return keep(s, 2, corners, mask);
    }
    if (n == 3) {
        *v = nearest_on_triangle(s[0], s[1], s[2], &mask);
        return keep(s, 3, corners, mask);
    }
    double best = INFINITY;
    V3 bv = v3(0, 0, 0);
    int bmask = 0, face = -1;
    for (int f = 0; f < 4; f++) {         /* face f leaves out corner f */
        int i = (f + 1) % 4, j = (f + 2) % 4, k = (f + 3) % 4;
        if (!beyond(s, i, j, k, f))
            continue;
        V3 p = nearest_on_triangle(s[i], s[j], s[k], &mask);
        double d = v3_norm2(p);
        if (d < best) {
            best = d;
            bv = p;
            bmask = mask;
            face = f;
        }
    }
    if (face < 0) {
        *v = v3(0, 0, 0);
        return 4;
    }
    corners[0] = (face + 1) % 4, corners[1] = (face + 2) % 4, corners[2] = (face + 3) % 4;
    *v = bv;
    return keep(s, 3, corners, bmask);
}

static inline void pad_range(const double *pads, int64_t lo, int64_t hi, double *small,
                             double *large)
{
    double a = INFINITY, b = 0.0;
    for (int64_t s = lo; s < hi; s++) {
        a = cp_min(a, pads[s]);
        b = cp_max(b, pads[s]);
    }
    *small = a, *large = b;
}

static inline double abs_max3(V3 a) { return cp_max(cp_max(fabs(a.x), fabs(a.y)), fabs(a.z)); }

/* ``(lower, upper)`` bounds of the distance between the padded hulls of points
 * ``lo_a:hi_a`` placed by ``m_a`` and ``lo_b:hi_b`` placed by ``m_b``: lower > 0 proves
 * them apart, upper is their distance or more (<= 0: they touch). Stops once the lower
 * bound reaches ``enough``, when the bounds agree to GJK_CONVERGED, or after
 * ``iterations`` steps. */
static void gjk_bounds(const double *points, const double *pads, int64_t lo_a, int64_t hi_a,
                       const double *m_a, int64_t lo_b, int64_t hi_b, const double *m_b,
                       double enough, int64_t iterations, double *lower_out, double *upper_out)
{
    V3 s[4];
    V3 a = support(points, lo_a, hi_a, m_a, v3(1.0, 0.0, 0.0));
    V3 b = support(points, lo_b, hi_b, m_b, v3(-1.0, 0.0, 0.0));
    V3 v = v3_sub(a, b);
    double scale = cp_max(abs_max3(a), abs_max3(b));
    double small_a, large_a, small_b, large_b;
    pad_range(pads, lo_a, hi_a, &small_a, &large_a);
    pad_range(pads, lo_b, hi_b, &small_b, &large_b);
    double slack = large_a + large_b;
    double lower = -INFINITY;
    int n = 0;
    for (int64_t step = 0; step < iterations; step++) {
        double vv = v3_norm2(v);
        if (!(vv > 0.0))                  /* touching (or NaN): nothing more to prove */
            break;
        a = support(points, lo_a, hi_a, m_a, v3_scale(v, -1.0));
        b = support(points, lo_b, hi_b, m_b, v);
        scale = cp_max(scale, cp_max(abs_max3(a), abs_max3(b)));
        V3 w = v3_sub(a, b);
        double wv = v3_dot(w, v);
        lower = cp_max(lower, wv / sqrt(vv));
        if (lower - slack - GJK_SLACK * (1.0 + scale) >= enough)
            break;
        if (vv - wv <= GJK_CONVERGED * vv)   /* converged: the bounds meet */
            break;
        s[n] = w;
        n = reduce(s, n + 1, &v);
        if (n == 4) {                     /* the simplex encloses the origin: cores overlap */
            v = v3(0.0, 0.0, 0.0);
            break;
        }
    }
    double rounding = GJK_SLACK * (1.0 + scale);
    double upper = sqrt(v3_norm2(v));
    if (!(upper > 0.0))
        lower = cp_min(lower, 0.0);
    *lower_out = lower - slack - rounding;
    *upper_out = upper - small_a - small_b + rounding;
}

/* ``(lower, upper)`` bounds of the distance between objects i and j at poses m_i, m_j
 * from their pairs of convex pieces (object k's are pieces[k]:pieces[k + 1], piece q's
 * padded points piece_starts[q]:piece_starts[q + 1] inside the ball centre[q], radius[q]
 * of its object's frame); see cadpipe.collision.convex.body_bounds. */
static void body_bounds(const double *points, const double *pads, const int64_t *piece_starts,
                        const double *centre, const double *radius, const int64_t *pieces,
                        int64_t i, const double *m_i, int64_t j, const double *m_j,
                        double enough, int64_t iterations, double *best_out, double *least_out)
{
    double best = INFINITY, least = INFINITY;
    for (int64_t p = pieces[i]; p < pieces[i + 1]; p++) {
        const double *cp = centre + 3 * p;
        double ci[3];
        for (int r = 0; r < 3; r++)
            ci[r] = m_i[4 * r] * cp[0] + m_i[4 * r + 1] * cp[1] + m_i[4 * r + 2] * cp[2] +
                    m_i[4 * r + 3];
        double ci_max = cp_max(cp_max(fabs(ci[0]), fabs(ci[1])), fabs(ci[2]));
        for (int64_t q = pieces[j]; q < pieces[j + 1]; q++) {
            const double *cq = centre + 3 * q;
            double cj[3];
            for (int r = 0; r < 3; r++)
                cj[r] = m_j[4 * r] * cq[0] + m_j[4 * r + 1] * cq[1] + m_j[4 * r + 2] * cq[2] +
                        m_j[4 * r + 3];
            double cj_max = cp_max(cp_max(fabs(cj[0]), fabs(cj[1])), fabs(cj[2]));
            double balls = sqrt((ci[0] - cj[0]) * (ci[0] - cj[0]) +
                                (ci[1] - cj[1]) * (ci[1] - cj[1]) +
                                (ci[2] - cj[2]) * (ci[2] - cj[2])) -
                           radius[p] - radius[q];
            balls -= GJK_SLACK * (1.0 + ci_max + cj_max + radius[p] + radius[q]);
            if (balls >= cp_min(best, enough)) {
                best = cp_min(best, balls);
                continue;
            }
            double low, high;
            gjk_bounds(points, pads, piece_starts[p], piece_starts[p + 1], m_i,
                       piece_starts[q], piece_starts[q + 1], m_j, cp_min(best, enough),
                       iterations, &low, &high);
            best = cp_min(best, cp_max(balls, low));
            least = cp_min(least, high);
            if (best <= 0.0) {
                *best_out = best, *least_out = least;
                return;
            }
        }
    }
    *best_out = best, *least_out = least;
}

/* The arguments of body_bounds before the objects, as the Python side passes them
 * (cadpipe.collision.convex.Pieces.arrays()). */
typedef struct {
    const double *points, *pads, *centre, *radius;
    const int64_t *piece_starts, *pieces;
} Pieces;

static int pieces_of(PyObject *const *args, Pieces *p, const char *kernel, int first)
{
    Arr a[6];
    static const int types[6] = {NPY_FLOAT64, NPY_FLOAT64, NPY_INT64, NPY_FLOAT64, NPY_FLOAT64,
                                 NPY_INT64};
    static const int dims[6] = {2, 1, 1, 2, 1, 1};
    for (int k = 0; k < 6; k++)
        if (!cp_array(args[first + k], types[k], dims[k], 0, &a[k], kernel, first + k))
            return 0;
    p->points = F64(a[0]), p->pads = F64(a[1]), p->piece_starts = I64(a[2]);
    p->centre = F64(a[3]), p->radius = F64(a[4]), p->pieces = I64(a[5]);
    return 1;
}

/* bounds(points, pads, lo_a, hi_a, m_a, lo_b, hi_b, m_b, enough, iterations)
 * -> (lower, upper) */
KERNEL(gjk_bounds)
{
    CP_NARGS(10);
    IN_F64(0, points, 2);
    IN_F64(1, pads, 1);
    IN_LONG(2, lo_a);
    IN_LONG(3, hi_a);
    IN_F64(4, m_a, 2);
    IN_LONG(5, lo_b);
    IN_LONG(6, hi_b);
    IN_F64(7, m_b, 2);
    IN_DOUBLE(8, enough);
    IN_LONG(9, iterations);
    double lower, upper;
    gjk_bounds(F64(points), F64(pads), lo_a, hi_a, F64(m_a), lo_b, hi_b, F64(m_b), enough,
               iterations, &lower, &upper);
    return Py_BuildValue("dd", lower, upper);
}

/* body_bounds(points, pads, piece_starts, centre, radius, pieces, i, m_i, j, m_j, enough,
 * iterations) -> (lower, upper) */
KERNEL(body_bounds)
{
    CP_NARGS(12);
    Pieces p;
    if (!pieces_of(args, &p, "body_bounds", 0))
        return NULL;
    IN_LONG(6, i);
    IN_F64(7, m_i, 2);
    IN_LONG(8, j);
    IN_F64(9, m_j, 2);
    IN_DOUBLE(10, enough);
    IN_LONG(11, iterations);
    double best, least;
    body_bounds(p.points, p.pads, p.piece_starts, p.centre, p.radius, p.pieces, i, F64(m_i), j,
                F64(m_j), enough, iterations, &best, &least);
    return Py_BuildValue("dd", best, least);
}

/* body_gaps(points, pads, piece_starts, centre, radius, pieces, first (E,), poses_a
 * (E, 4, 4), second (E,), poses_b, enough (E,), iterations, out (E,)): the lower bound of
 * body_bounds of each entry. */
KERNEL(body_gaps)
{
    CP_NARGS(13);
    Pieces p;
    if (!pieces_of(args, &p, "body_gaps", 0))
        return NULL;
    IN_I64(6, first, 1);
    IN_F64(7, poses_a, 3);
    IN_I64(8, second, 1);
    IN_F64(9, poses_b, 3);
    IN_F64(10, enough, 1);
    IN_LONG(11, iterations);
    OUT_F64(12, out, 1);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp e = 0; e < first.size; e++) {
        double best, least;
        body_bounds(p.points, p.pads, p.piece_starts, p.centre, p.radius, p.pieces,
                    I64(first)[e], F64(poses_a) + 16 * e, I64(second)[e],
                    F64(poses_b) + 16 * e, F64(enough)[e], iterations, &best, &least);
        F64(out)[e] = best;
    }
    Py_END_ALLOW_THREADS
    Py_RETURN_NONE;
}

static PyMethodDef convex_methods[] = {
    ENTRY(gjk_bounds, "(points, pads, lo_a, hi_a, m_a, lo_b, hi_b, m_b, enough, iterations)"
                      " -> (lower, upper) bounds of two padded hulls' distance"),
    ENTRY(body_bounds, "(points, pads, piece_starts, centre, radius, pieces, i, m_i, j, m_j,"
                       " enough, iterations) -> (lower, upper) of two objects' pieces"),
    ENTRY(body_gaps, "(points, pads, piece_starts, centre, radius, pieces, first, poses_a,"
                     " second, poses_b, enough, iterations, out): lower bounds per entry"),
    END_ENTRIES};
