/* Signed distances of points to round-cone units conv(B(a, ra), B(b, rb)): a pipe's
 * units (cadpipe.collision.capsules), and the fixture queries' walls (fixture.c). */
#include "native.h"

/* Signed distance of point ``p`` (3) to the unit conv(B(a, ra), B(b, rb)) (``a``, ``b``
 * (3)): exact outside, the distance to the unit's own boundary inside. Reduced to the
 * unit's half-plane (axial y along a -> b, radial x) where the side line touches both end
 * circles; w, the coordinate along that line, tells which of the three boundary pieces
 * is nearest. A unit one ball of which swallows the other (or of length 0) is the
 * bigger ball. */
static inline double round_cone_at(const double *p, const double *a, const double *b, double ra,
                                   double rb)
{
    double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
    double length = sqrt(ux * ux + uy * uy + uz * uz);
    double safe = length > 0 ? length : 1.0;
    double rx = p[0] - a[0], ry = p[1] - a[1], rz = p[2] - a[2];
    double y = (rx * ux + ry * uy + rz * uz) / safe;
    double x = sqrt(cp_max(rx * rx + ry * ry + rz * rz - y * y, 0.0));
    double delta = (ra - rb) / safe;            /* sine of the cone's half angle */
    double to_a = hypot(x, y) - ra;
    double to_b = hypot(x, y - length) - rb;
    if (!(length > 0 && fabs(delta) < 1.0))
        return ra >= rb ? to_a : to_b;
    double cos_ = sqrt(1.0 - delta * delta);
    double w = y * cos_ - x * delta;
    if (w < 0)
        return to_a;
    if (w > length * cos_)
        return to_b;
    return x * cos_ + y * delta - ra;
}

/* round_cones(points (K, 3), a (K, 3), b (K, 3), ra (K,), rb (K,), out (K,)): point k
 * against unit k. */
KERNEL(round_cones)
{
    CP_NARGS(6);
    IN_F64(0, points, 2);
    IN_F64(1, a, 2);
    IN_F64(2, b, 2);
    IN_F64(3, ra, 1);
    IN_F64(4, rb, 1);
    OUT_F64(5, out, 1);
    npy_intp n = out.shape[0];
    if (points.size < 3 * n || a.size < 3 * n || b.size < 3 * n || ra.size < n || rb.size < n) {
        PyErr_SetString(PyExc_ValueError, "round_cones: shapes differ");
        return NULL;
    }
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp k = 0; k < n; k++)
        F64(out)[k] = round_cone_at(F64(points) + 3 * k, F64(a) + 3 * k, F64(b) + 3 * k,
                                    F64(ra)[k], F64(rb)[k]);
    Py_END_ALLOW_THREADS
    Py_RETURN_NONE;
}

/* chain_signed_distance(points (P, 3), a (U, 3), b (U, 3), ra (U,), rb (U,), out (P,)):
 * each point's least signed distance over the units (the union's sign exact; inside,
 * the depth within the deepest unit). */
KERNEL(chain_signed_distance)
{
    CP_NARGS(6);
    IN_F64(0, points, 2);
    IN_F64(1, a, 2);
    IN_F64(2, b, 2);
    IN_F64(3, ra, 1);
    IN_F64(4, rb, 1);
    OUT_F64(5, out, 1);
    npy_intp n = points.shape[0], units = a.shape[0];
    if (out.shape[0] != n || b.shape[0] != units || ra.shape[0] != units ||
        rb.shape[0] != units) {
        PyErr_SetString(PyExc_ValueError, "chain_signed_distance: shapes differ");
        return NULL;
    }
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp k = 0; k < n; k++) {
        double best = INFINITY;
        for (npy_intp u = 0; u < units; u++)
            best = cp_min(best, round_cone_at(F64(points) + 3 * k, F64(a) + 3 * u,
                                              F64(b) + 3 * u, F64(ra)[u], F64(rb)[u]));
        F64(out)[k] = best;
    }
    Py_END_ALLOW_THREADS
    Py_RETURN_NONE;
}

static PyMethodDef capsules_methods[] = {
    ENTRY(round_cones, "(points, a, b, ra, rb, out): signed distance of point k to unit k"),
    ENTRY(chain_signed_distance, "(points (P, 3), a, b (U, 3), ra, rb (U,), out (P,)): "
                                 "signed distance to the union of the units"),
    END_ENTRIES};
