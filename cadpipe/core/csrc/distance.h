/* The one family of point, segment and triangle distances, in scalars.
 *
 * Every walk that meets a pair of leaves calls one of these, millions of times a
 * query: they take coordinates, not small arrays, and are inlined into their callers
 * (one translation unit). The numpy forms for batches of pairs (capsules.py) follow
 * the same formulas.
 */
#ifndef CP_DISTANCE_H
#define CP_DISTANCE_H

#include <float.h>
#include <math.h>

typedef struct { double x, y, z; } V3;

static inline V3 v3(double x, double y, double z) { V3 v = {x, y, z}; return v; }
static inline V3 v3_at(const double *p) { V3 v = {p[0], p[1], p[2]}; return v; }
static inline V3 v3_sub(V3 a, V3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline V3 v3_add(V3 a, V3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline V3 v3_scale(V3 a, double s) { return v3(a.x * s, a.y * s, a.z * s); }
static inline double v3_dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline V3 v3_cross(V3 a, V3 b)
{
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline double v3_norm2(V3 a) { return v3_dot(a, a); }
static inline void v3_store(double *out, V3 a) { out[0] = a.x; out[1] = a.y; out[2] = a.z; }

/* Point of segment ab nearest the origin, and the corners that span it (bits 1, 2). */
static inline V3 nearest_on_segment(V3 a, V3 b, int *mask)
{
    V3 e = v3_sub(b, a);
    double t = -v3_dot(a, e);
    if (t <= 0.0) {
        *mask = 1;
        return a;
    }
    double length = v3_norm2(e);
    if (t >= length) {
        *mask = 2;
        return b;
    }
    t /= length;
    *mask = 3;
    return v3_add(a, v3_scale(e, t));
}

/* Point of triangle abc nearest the origin, and the corners that span it (bits 1, 2,
 * 4): the Voronoi regions of its corners, edges and face in turn (Ericson, Real-Time
 * Collision Detection, 5.1.5; a flat triangle by its nearest edge). GJK's simplex
 * step, and every point-triangle distance. */
static inline V3 nearest_on_triangle(V3 a, V3 b, V3 c, int *mask)
{
    V3 ab = v3_sub(b, a), ac = v3_sub(c, a);
    double d1 = -v3_dot(ab, a), d2 = -v3_dot(ac, a);
    if (d1 <= 0.0 && d2 <= 0.0) {
        *mask = 1;
        return a;
    }
    double d3 = -v3_dot(ab, b), d4 = -v3_dot(ac, b);
    if (d3 >= 0.0 && d4 <= d3) {
        *mask = 2;
        return b;
    }
    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
        double t = d1 / (d1 - d3);
        *mask = 3;
        return v3_add(a, v3_scale(ab, t));
    }
    double d5 = -v3_dot(ab, c), d6 = -v3_dot(ac, c);
    if (d6 >= 0.0 && d5 <= d6) {
        *mask = 4;
        return c;
    }
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
        double t = d2 / (d2 - d6);
        *mask = 5;
        return v3_add(a, v3_scale(ac, t));
    }
    double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0) {
        double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        *mask = 6;
        return v3_add(b, v3_scale(v3_sub(c, b), t));
    }
    double total = va + vb + vc;
    if (!(total > 0.0)) {      /* a degenerate (flat) triangle: its nearest edge */
        int m, n;
        V3 p = nearest_on_segment(a, b, &m), q = nearest_on_segment(b, c, &n);
        if (v3_norm2(q) < v3_norm2(p)) {
            p = q;
            m = n << 1;
        }
        q = nearest_on_segment(a, c, &n);
        if (v3_norm2(q) < v3_norm2(p)) {
            p = q;
            m = (n & 1) | ((n & 2) << 1);
        }
        *mask = m;
        return p;
    }
    double v = vb / total, w = vc / total;
    *mask = 7;
    return v3_add(v3_add(a, v3_scale(ab, v)), v3_scale(ac, w));     /* (a + v ab) + w ac */
}

/* The point of triangle ``t`` (9 coordinates, corner by corner) nearest ``p``. */
static inline V3 closest_on_triangle(V3 p, const double *t)
{
    int mask;
    V3 q = nearest_on_triangle(v3_sub(v3_at(t), p), v3_sub(v3_at(t + 3), p),
                               v3_sub(v3_at(t + 6), p), &mask);
    return v3_add(q, p);
}

/* ``1 / x``, and 0 where ``x`` is too small to invert (a zero-length segment's squared
 * length): core.distance.inverse. */
static inline double inverse(double x) { return x > DBL_MIN ? 1.0 / x : 0.0; }

/* Parameters ``(s, t)`` of the closest points of ``p + s u`` and ``q + t v`` from the
 * dot products of ``u``, ``v`` and ``r = p - q`` and the inverse squared lengths:
 * Ericson's clamping (5.1.9), ``s`` always recomputed from the clamped ``t``
 * (core.distance.segment_params, the numpy form). */
static inline void segment_params(double uu, double vv, double uv, double ur, double vr,
                                  double inv_uu, double inv_vv, double *s_out, double *t_out)
{
    double square = uu * vv;
    double den = square - uv * uv;
    double s = 0.0;
    if (den > 1e-14 * square) {
        double d = den > 1e-300 ? den : 1e-300;
        s = (uv * vr - ur * vv) / d;
        s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
    }
    double t = (uv * s + vr) * inv_vv;
    t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
    s = (uv * t - ur) * inv_uu;
    *s_out = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
    *t_out = t;
}

/* The closest points' parameters of segments ``p + s u`` and ``q + t v``. */
static inline void segments_closest(V3 p, V3 u, V3 q, V3 v, double *s, double *t)
{
    V3 r = v3_sub(p, q);
    double uu = v3_norm2(u), vv = v3_norm2(v);
    segment_params(uu, vv, v3_dot(u, v), v3_dot(u, r), v3_dot(v, r), inverse(uu),
                   inverse(vv), s, t);
}

/* Distance from point ``x`` to the segment ``p + s u`` (s in [0, 1]), and that s. */
static inline double point_segment(V3 x, V3 p, V3 u, double *s_out)
{
    V3 w = v3_sub(x, p);
    double uu = v3_norm2(u);
    double s = uu > 0.0 ? v3_dot(w, u) / uu : 0.0;
    s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
    *s_out = s;
    return sqrt(v3_norm2(v3_sub(w, v3_scale(u, s))));
}

/* Distance from segment ``a``-``b`` to triangle ``t`` (9), the closest points written to
 * ``near`` (on the segment) and ``far`` (on the triangle); 0 where the segment pierces
 * the triangle. */
static inline double segment_triangle(V3 a, V3 b, const double *t, V3 *near, V3 *far)
{
    V3 u = v3_sub(b, a);
    V3 t0 = v3_at(t), t1 = v3_at(t + 3), t2 = v3_at(t + 6);
    V3 n = v3_cross(v3_sub(t1, t0), v3_sub(t2, t0));
    double da = v3_dot(n, v3_sub(a, t0)), db = v3_dot(n, v3_sub(b, t0));
    if (((da <= 0 && 0 <= db) || (db <= 0 && 0 <= da)) && da != db) {
        double f = da / (da - db);
        V3 x = v3_add(a, v3_scale(u, f));
        V3 c = closest_on_triangle(x, t);
        if (v3_norm2(v3_sub(c, x)) <= 1e-30 * (1.0 + x.x * x.x + x.y * x.y + x.z * x.z)) {
            *near = x;
            *far = c;
            return 0.0;
        }
    }
    double best = INFINITY;
    for (int k = 0; k < 2; k++) {           /* the segment's ends against the triangle */
        V3 p = k == 0 ? a : b;
        V3 c = closest_on_triangle(p, t);
        double d = sqrt(v3_norm2(v3_sub(c, p)));
        if (d < best) {
            best = d;
            *near = p;
            *far = c;
        }
    }
    for (int k = 0; k < 3; k++) {           /* the segment against each edge */
        V3 q = v3_at(t + 3 * k), v = v3_sub(v3_at(t + 3 * ((k + 1) % 3)), q);
        double s, w;
        segments_closest(a, u, q, v, &s, &w);
        V3 p = v3_add(a, v3_scale(u, s)), r = v3_add(q, v3_scale(v, w));
        double d = sqrt(v3_norm2(v3_sub(p, r)));
        if (d < best) {
            best = d;
            *near = p;
            *far = r;
        }
    }
    return best;
}

#endif
