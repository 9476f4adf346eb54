"""Step S1: the path a pipe follows, as a validated polyline.

A :class:`Path` is an immutable ``(N, 3)`` polyline, open or closed. Smooth curves
are fitted through control points with scipy's cubic splines and discretized at an
arc-length step ``tau`` or a chordal tolerance; polyline corners can be rounded
with fillets of a given bend radius.

Segment, tangent and corner geometry is computed by :class:`Polylines` for many
polylines at once (a splice of a thousand pipes); a :class:`Path` is a batch of one.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from cadpipe import limits
from cadpipe._validate import as_points, as_positive
from cadpipe.core.vec import cross, dot, norm, unit
from cadpipe.errors import GeometryError, InputError
from cadpipe.geometry.ragged import Groups, blocks
from cadpipe.core.transform import as_matrix, placed_points

#: consecutive points closer than this fraction of the path's extent are merged
DUPLICATE_TOLERANCE = 1e-9
#: a turn beyond this (radians) reverses the path: the segments there have no bisector,
#: and a tube must turn round in a ball joint (the swept solid)
REVERSAL = np.pi - 1e-9
#: default largest turn, in radians, of one segment of a fillet's arc (5 degrees)
ARC_STEP = float(np.radians(5.0))


class Path:
    """A polyline in 3D, open or closed.

    Parameters
    ----------
    points : (N, 3) array_like
        Finite coordinates. Consecutive duplicates (within 1e-9 of the extent) are
        dropped; for a closed path a last point equal to the first is dropped too.
    closed : bool
        Whether the last point connects back to the first.
    """

    __slots__ = ("_points", "_xyz", "_closed", "_tolerance", "__dict__")

    def __init__(self, points: ArrayLike, closed: bool = False):
        pts = as_points(points, "points", min_count=2)
        xyz = np.ascontiguousarray(pts.T)        # component-first: fast along the path
        extent = float((xyz.max(axis=1) - xyz.min(axis=1)).max())
        tol = DUPLICATE_TOLERANCE * max(extent, 1.0)
        keep = np.ones(len(pts), bool)
        keep[1:] = norm(np.diff(xyz, axis=1), 0) > tol
        if not keep.all():
            pts, xyz = pts[keep], xyz[:, keep]
        if closed and len(pts) > 1 and np.linalg.norm(pts[-1] - pts[0]) <= tol:
            pts, xyz = pts[:-1], xyz[:, :-1]
        need = 3 if closed else 2
        if len(pts) < need:
            raise InputError(f"a{' closed' if closed else 'n open'} path needs at least "
                             f"{need} distinct points, got {len(pts)} after dropping duplicates",
                             key="points")
        pts = np.array(pts)                       # our own copy, frozen
        pts.flags.writeable = False
        self._points = pts
        self._xyz = np.ascontiguousarray(xyz)
        self._closed = bool(closed)
        self._tolerance = tol                     # points closer than this are one point

    def __repr__(self):
        kind = "closed" if self._closed else "open"
        return f"<cadpipe.Path {kind}, {len(self._points)} points, length {self.length:.6g}>"

    def __len__(self):
        return len(self._points)

    @property
    def points(self) -> np.ndarray:
        """(N, 3) float64, read-only."""
        return self._points

    @property
    def closed(self) -> bool:
        """Whether the last point connects back to the first."""
        return self._closed

    # -- derived geometry (the batch-of-one view of :class:`Polylines`) -------
    @cached_property
    def _lines(self):
        return Polylines(self._xyz, Groups([len(self._points)], self._closed))

    def _rows(self, vectors):
        """(M, 3) rows of the component-first ``vectors``, one per segment."""
        return np.ascontiguousarray(vectors[:, : len(self._points) - (not self._closed)].T)

    @cached_property
    def segments(self) -> np.ndarray:
        """(M, 3) vectors from each point to the next (M = N - 1, or N when closed)."""
        return self._rows(self._lines.segments)

    @cached_property
    def segment_lengths(self) -> np.ndarray:
        """(M,) length of each segment, in path units."""
        return self._lines.segment_lengths[: len(self._points) - (not self._closed)]

    @cached_property
    def directions(self) -> np.ndarray:
        """(M, 3) unit direction of each segment."""
        return self._rows(self._lines.directions)

    @cached_property
    def length(self) -> float:
        """Total length, with the closing segment of a closed path, in path units."""
        return float(self._lines.lengths[0])

    @cached_property
    def arc_length(self) -> np.ndarray:
        """(N,) distance along the path from the first point to each point."""
        return self._lines.arc_length

    @cached_property
    def turning_angles(self) -> np.ndarray:
        """(N,) angle in radians between the incoming and outgoing segment at each point."""
        return self._lines.turning_angles

    @cached_property
    def tangents(self) -> np.ndarray:
        """(N, 3) unit tangents: the bisector of the adjacent segments at interior points.

        A ring in the plane normal to the bisector is a miter joint, which keeps a
        tube's full radius through a corner. Where the path reverses (a turn beyond
        :data:`REVERSAL`) there is no bisector; the tangent is then a unit vector across
        the incoming segment (a pipe turns round there in a ball joint).
        """
        return np.ascontiguousarray(self._lines.tangents.T)

    @cached_property
    def bend_directions(self) -> np.ndarray:
        """(N, 3) unit vector in each corner's plane, perpendicular to the tangent
        (zero where the path is straight)."""
        return np.ascontiguousarray(self._lines.bend_directions.T)

    # -- new paths -----------------------------------------------------------
    def resample(self, step: float) -> Path:
        """Subdivide every segment into equal pieces no longer than ``step``.

        Corners are kept, so a polyline keeps its shape exactly.

        Parameters
        ----------
        step : float
            Longest piece, in path units, > 0.

        Returns
        -------
        path : Path
        """
        step = float(as_positive(step, "step"))
        limits.check("max_samples", float(np.sum(self.segment_lengths / step)),
                     f"resampling a path {self.length:.6g} long every {step:g}", key="step")
        counts = np.maximum(np.ceil(self.segment_lengths / step).astype(np.int64), 1)
        runs = Groups(counts)
        seg, frac = runs.index, runs.local() / runs.spread(counts)
        pts = self._points[seg] + frac[:, None] * self.segments[seg]
        if not self._closed:
            pts = np.vstack([pts, self._points[-1:]])
        return Path(pts, closed=self._closed)

    def _fillet_counts(self, bend_radius, max_angle):
        """Validated radius, corner mask and new points per old point of a fillet."""
        radius = float(as_positive(bend_radius, "bend_radius"))
        alpha = self.turning_angles
        corner = alpha > 1e-9
        counts = np.where(corner, np.maximum(np.ceil(alpha / max_angle), 1).astype(np.int64) + 1, 1)
        return radius, corner, counts

    def fillet_sources(self, bend_radius: float, max_angle: float = ARC_STEP) -> np.ndarray:
        """Which point of this path each point of :meth:`filleted` comes from.

        Parameters
        ----------
        bend_radius, max_angle : float
            The fillet's, as for :meth:`filleted`.

        Returns
        -------
        source : (M,) int64
            Index into this path's points, for carrying per-point data (radii) across.
        """
        counts = self._fillet_counts(bend_radius, max_angle)[2]
        return np.repeat(np.arange(len(self)), counts)

    def filleted(self, bend_radius: float, max_angle: float = ARC_STEP) -> Path:
        """This path with each corner rounded by a circular arc of radius ``bend_radius``.

        The arc is tangent to both segments and sampled every ``max_angle``
        radians; :meth:`fillet_sources` says which old point each new one replaces.

        Parameters
        ----------
        bend_radius : float
            Arc radius, in path units, > 0.
        max_angle : float
            Largest angle in radians one arc segment turns.

        Returns
        -------
        path : Path
            The rounded path, M >= N points.

        Raises
        ------
        GeometryError
            Where a segment is too short for the arcs at its two ends.
        """
        radius, corner, counts = self._fillet_counts(bend_radius, max_angle)
        alpha = self.turning_angles
        setback = np.where(corner, radius * np.tan(alpha / 2), 0.0)
        before = np.roll(setback, -1) if self._closed else np.append(setback[1:], 0.0)
        room = self.segment_lengths - setback[: len(self.segment_lengths)] - \
            before[: len(self.segment_lengths)]
        if (room < -1e-12 * max(self.length, 1.0)).any():
            i = int(np.argmin(room))
            raise GeometryError(
                f"bend_radius={radius:g} does not fit between path points {i} and "
                f"{(i + 1) % len(self)}: the segment is {self.segment_lengths[i]:.6g} long but "
                f"the arcs need {setback[i] + before[i]:.6g}; use a smaller bend_radius")
        d_in, d_out = self._lines.incoming.T, self._lines.directions.T
        runs = Groups(counts)
        source = runs.index
        t = runs.local() / np.repeat(np.maximum(counts - 1, 1), counts)
        p = self._points[source]
        a = p - setback[source, None] * d_in[source]          # arc start (tangent point)
        b = p + setback[source, None] * d_out[source]         # arc end
        # the centre lies along the inward normal of the incoming segment at the tangent point
        inward = unit(d_out[source] - dot(d_out[source], d_in[source])[:, None]
                       * d_in[source])
        centre = a + radius * inward
        al = alpha[source]
        sin_al = np.sin(al)
        safe = np.where(sin_al > 1e-12, sin_al, 1.0)
        e0, e1 = a - centre, b - centre
        w0 = np.where(sin_al > 1e-12, np.sin((1 - t) * al) / safe, 1 - t)
        w1 = np.where(sin_al > 1e-12, np.sin(t * al) / safe, t)
        arc = centre + w0[:, None] * e0 + w1[:, None] * e1
        pts = np.where(corner[source][:, None], arc, p)
        return Path(pts, closed=self._closed)

    def trimmed(self, start: float = 0.0, end: float = 0.0) -> Path:
        """This open path with ``start`` and ``end`` arc length removed from its ends.

        Parameters
        ----------
        start, end : float
            Arc length to remove at each end, in path units, >= 0.

        Returns
        -------
        path : Path
            The remaining piece. Its point ``i`` lies at arc length
            ``start + path.arc_length[i]`` on this path.
        """
        if self._closed:
            raise InputError("a closed path has no ends to trim", key="trimmed")
        lo, hi = float(start), self.length - float(end)
        if not 0.0 <= lo < hi <= self.length:
            raise GeometryError(f"cannot trim {start:g} and {end:g} off a path "
                                f"{self.length:.6g} long; the pipe is too short")
        arc = self.arc_length
        tol = 2 * self._tolerance
        inner = (arc > lo + tol) & (arc < hi - tol)     # keep the cut points distinct
        s = np.concatenate([[lo], arc[inner], [hi]])
        pts = np.stack([np.interp(s, arc, self._points[:, c]) for c in range(3)], axis=1)
        return Path(pts)

    def reversed(self) -> Path:
        """The same path travelled the other way.

        Returns
        -------
        path : Path
        """
        return Path(self._points[::-1], closed=self._closed)

    def transformed(self, matrix: ArrayLike) -> Path:
        """The path moved by a 4x4 homogeneous matrix.

        Parameters
        ----------
        matrix : (4, 4) array_like
            Rotation, scale and translation, as :meth:`Mesh.transformed` takes.

        Returns
        -------
        path : Path
        """
        m = as_matrix(matrix)
        return Path(placed_points(self._points, m), closed=self._closed)

    # -- fitted curves -------------------------------------------------------
    @classmethod
    def spline(cls, points: ArrayLike, step: float | None = None, *,
               tolerance: float | None = None, closed: bool = False) -> Path:
        """Fit a cubic spline through ``points`` and discretize it.

        The spline interpolates every control point (chord-length parameters; periodic
        when ``closed``). Sampling is even in arc length with segments no longer than
        ``step``, and denser where curvature needs it to keep the chordal deviation
        below ``tolerance``. Without either, ``tolerance`` is 1e-4 of the control
        polygon's extent.

        Parameters
        ----------
        points : (K, 3) array_like
            Control points the curve passes through, K >= 2 (3 when closed).
        step : float, optional
            Longest segment, in path units.
        tolerance : float, optional
            Largest distance between the curve and its polyline, in path units.
        closed : bool
            Fit a periodic curve through the points and back to the first.

        Returns
        -------
        path : Path
        """
        from scipy.interpolate import CubicSpline, make_interp_spline

        control = cls(points, closed=closed).points
        if closed:
            control = np.vstack([control, control[:1]])
        chord = norm(np.diff(control, axis=0))
        u = np.concatenate([[0.0], np.cumsum(chord)])
        if closed:
            curve = CubicSpline(u, control, bc_type="periodic")
        else:
            curve = make_interp_spline(u, control, k=min(3, len(control) - 1))
        if step is None and tolerance is None:
            tolerance = 1e-4 * float(np.ptp(control, axis=0).max())
        step = np.inf if step is None else float(as_positive(step, "step"))
        tolerance = None if tolerance is None else float(as_positive(tolerance, "tolerance"))

        # a dense table of arc length and curvature drives the final placement
        dense_u = np.linspace(0.0, u[-1], 64 * len(control) + 1)
        d1, d2 = curve(dense_u, 1), curve(dense_u, 2)
        speed = norm(d1)
        # a cusp (zero speed) has no curvature to resolve: sample it at the base density
        curvature = np.divide(norm(cross(d1, d2)), speed ** 3,
                              out=np.zeros_like(speed), where=speed > 1e-12 * speed.max())
        density = np.full_like(speed, 1.0 / step)                 # points per unit length
        if tolerance is not None:
            density = np.maximum(density, np.sqrt(curvature / (8.0 * tolerance)))
        du = np.diff(dense_u)
        ds = 0.5 * (speed[1:] + speed[:-1]) * du
        weight = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * ds)])
        needed = float(weight[-1]) if np.isfinite(weight[-1]) else np.inf
        limits.check("max_samples", needed, "this fitted path",
                     key="step" if np.isfinite(step) else "tolerance")
        n_seg = max(int(np.ceil(needed)), 3 if closed else 1)
        target = np.linspace(0.0, weight[-1], n_seg + 1)
        samples = curve(np.interp(target, weight, dense_u))
        if closed:
            samples = samples[:-1]
        return cls(samples, closed=closed)


def polylines(paths):
    """The paths' geometry as one :class:`Polylines` batch (a lone path's own, cached)."""
    if len(paths) == 1:
        return paths[0]._lines
    return Polylines(np.concatenate([p._xyz for p in paths], axis=1),
                     Groups([len(p) for p in paths], [p.closed for p in paths]))


def _rows(table, rows, doc):
    """A property: some rows of one of :class:`Polylines`' per-point tables."""
    return property(lambda self: getattr(self, table)[rows], doc=doc)


class Polylines:
    """Segment, corner and tangent geometry of many polylines in one set of arrays.

    Parameters
    ----------
    xyz : (3, N) array
        The polylines' points, concatenated, component-first (validated already: see
        :class:`Path`). Every vector array here is component-first too, so each
        operation runs over long contiguous rows.
    groups : Groups
        Which points belong to which polyline, and which polylines are closed.

    Every per-segment array has one column per point: column i is the segment
    leaving point i. An open polyline's last point leaves nowhere; its column
    repeats the previous segment, so directions there are the end direction, and
    sums and running sums over segments leave it out.
    """

    def __init__(self, xyz, groups):
        self.xyz = xyz
        self.groups = groups

    @cached_property
    def _segments(self):
        """(8, N): segment (rows 0-2), unit direction (3-5), length (6) and arc length
        from the polyline's start (7) at every point, in one allocation."""
        p, g = self.xyz, self.groups
        out = np.empty((8, g.size))
        segments = out[0:3]
        np.subtract(p[:, 1:], p[:, :-1], out=segments[:, :-1])
        last = g.last
        segments[:, last] = np.where(g.closed, p[:, g.first] - p[:, last],
                                     segments[:, last - 1])
        np.sqrt(dot(segments, segments, 0), out=out[6])
        np.divide(segments, out[6], out=out[3:6])
        g.exclusive_cumsum(out[6], out=out[7])
        return out

    segments = _rows("_segments", slice(0, 3), "(3, N) vector from each point to the next.")
    directions = _rows("_segments", slice(3, 6), "(3, N) unit direction of each segment: the "
                       "outgoing direction at each point.")
    segment_lengths = _rows("_segments", 6, "(N,) length of each segment.")
    arc_length = _rows("_segments", 7, "(N,) distance along each polyline from its first point.")

    @property
    def incoming(self):
        """(3, N) unit direction of the segment arriving at each point (an open
        polyline's first point takes its outgoing direction)."""
        return self.groups.preceding(self.directions)

    @cached_property
    def lengths(self):
        """(G,) length of each polyline, with the closing segment of a closed one."""
        g = self.groups
        last = g.last
        return self.arc_length[last] + np.where(g.closed, self.segment_lengths[last], 0.0)

    @cached_property
    def _corners(self):
        """(8, N): tangent (rows 0-2), bend direction (3-5), turning angle (6) and miter
        stretch (7) at every point, computed block by block."""
        out = np.empty((8, self.groups.size))
        d = self.directions
        for rows in blocks(self.groups.size):
            d_in, d_out = self.groups.preceding(d, rows.start, rows.stop), d[:, rows]
            turn = out[6, rows]
            np.arccos(dot(d_in, d_out, 0).clip(-1.0, 1.0), out=turn)
            bisector = d_in + d_out
            size = norm(bisector, 0)
            np.divide(bisector, np.where(size > 0, size, 1.0), out=out[0:3, rows])
            back = turn > REVERSAL                                # no bisector: any normal
            if back.any():
                out[0:3, rows][:, back] = _across(d_in[:, back])
            np.multiply(unit(d_out - d_in, 0), turn > 1e-12, out=out[3:6, rows])
            with np.errstate(divide="ignore"):                    # |d_in + d_out| = 2 cos(turn/2)
                np.divide(2.0, np.where(back, 0.0, size), out=out[7, rows])
        return out

    tangents = _rows("_corners", slice(0, 3), "(3, N) unit bisectors of the adjacent "
                     "segments; where a polyline reverses (a turn beyond :data:`REVERSAL`) a "
                     "unit vector across the incoming segment.")
    bend_directions = _rows("_corners", slice(3, 6), "(3, N) unit vector in each corner's plane, "
                            "across the tangent (zero where the polyline is straight).")
    turning_angles = _rows("_corners", 6, "(N,) angle between the incoming and outgoing "
                           "segment at each point.")
    miter_stretch = _rows("_corners", 7, "(N,) ``1 / cos(turn / 2)``: how far a ring in the "
                          "bisector plane reaches along the bend to stay on both segments' "
                          "cylinders (infinite where the polyline reverses).")


def _across(d):
    """(3, K) unit vectors across the (3, K) unit vectors ``d``: ``d x e`` for the axis
    ``e`` least aligned with each."""
    axis = np.zeros_like(d)
    axis[np.argmin(np.abs(d), axis=0), np.arange(d.shape[1])] = 1.0
    return unit(cross(d, axis, 0), 0)
