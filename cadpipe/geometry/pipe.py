"""Steps S2-S4: a pipe of regular n-gon rings along a path, closed into a solid.

A :class:`Pipe` is a description (path, radii, sides, caps, frame, ...); its
:meth:`Pipe.mesh` builds the watertight, outward-facing triangle mesh. The
pieces a splice needs (rings, frames) are public, so a transition between two
pipes is built from the same rings the pipes themselves use.
"""

import dataclasses
import warnings
from dataclasses import KW_ONLY, dataclass
from collections.abc import Mapping
from functools import cached_property, partial
from typing import Any

import numpy as np

from cadpipe import _deprecated, limits
from cadpipe._validate import as_choice, as_int, as_positive
from cadpipe.core.vec import cross
from cadpipe.errors import GeometryError, InputError
from cadpipe.geometry.frames import FRAME_MODES, MAX_TWIST_STEP, as_direction
from cadpipe.geometry.loft import Surface, write_fan
from cadpipe.geometry.bands import band_triangles, clearance
from cadpipe.geometry.cover import round_cone_covers
from cadpipe.geometry.clearance import (BALL_REACH, BALL_SIDES, Folds, local_folds,
                                        piece_meets_units, reach, segment_distance)
from cadpipe.geometry.mesh import Mesh
from cadpipe.geometry.path import Path, polylines
from cadpipe.geometry.rings import Tubes, ring_basis, square_rings

CAP_STYLES = ("flat", "round")
CORNER_STYLES = ("miter", "round")
MAX_SIDES = 4096


def sides_for_tolerance(radius, tolerance):
    """Fewest sides whose polygon stays within ``tolerance`` of a circle of ``radius``."""
    ratio = 1.0 - float(tolerance) / float(radius)
    if ratio <= -1.0:
        return 3
    return max(3, int(np.ceil(np.pi / np.arccos(max(ratio, -1.0)) - 1e-9)))


def _frozen(values):
    out = np.array(values, dtype=np.float64)
    out.flags.writeable = False
    return out


def _filleted_radii(path, bend, radii, filleted):
    """``radii`` carried onto ``filleted = path.filleted(bend)``: per source point, or,
    where arcs that consume a segment made the filleted path drop repeated points
    (0.1 raised a numpy broadcast error there), by arc-length fraction."""
    source = path.fillet_sources(bend)
    if len(source) == len(filleted):
        return radii[source]
    along = filleted.arc_length / filleted.length * path.length
    return np.interp(along, path.arc_length, radii)


def _cone_section(r_other, r_here, length):
    """Radius, at the ring of ``r_here``, of the round cone ``conv(B(other, r_other),
    B(here, r_here))`` ``length`` apart (its section in the plane square to the axis):
    ``r_here`` at the wide end; at the narrow end the side line, ``r_here / cos(a)``
    with ``sin a = (r_other - r_here) / length``, where that line already runs there,
    else the wide ball's own section ``sqrt(r_other**2 - length**2)``."""
    sine = np.clip((r_other - r_here) / length, 0.0, 1.0)
    cosine = np.sqrt(1.0 - sine ** 2)
    on_line = length >= r_other * sine                 # past the side's tangent point
    with np.errstate(divide="ignore", invalid="ignore"):
        line = r_here / cosine
    ball = np.sqrt(np.maximum(r_other ** 2 - length ** 2, 0.0))
    return np.where(sine <= 0, r_here, np.where(on_line, line, np.maximum(ball, r_here)))


def envelope_factor(sides):
    """Circumradius over inradius of a regular polygon: ``1 / cos(pi / sides)``."""
    return 1.0 / np.cos(np.pi / sides)


@dataclass(frozen=True, eq=False, repr=False)
class Pipe:
    """A tube of regular ``sides``-gon rings along a path: an immutable value.

    Change a setting with :meth:`replace` (or :func:`dataclasses.replace`); every
    derived array (rings, frames, checks) is computed once from the settings, which
    cannot be set, so it never goes stale.

    Parameters
    ----------
    path : Path or (N, 3) array_like
        The tube's axis, in metres.
    radius : float or (N,) array_like
        Tube radius, or one per path point (read back as :attr:`radii`).
    sides : int, optional
        Vertices per ring (3 to 4096). Chosen from ``tolerance`` when omitted (16 when
        neither is given); a ``sides`` given wins over ``tolerance``.
    caps : {"flat", "round"} or (start, end) pair of them
        End caps of an open path; a closed path needs none.
    envelope : bool
        False: ring vertices on the circle (the polygon lies inside the round tube).
        True: a conservative safety envelope: the solid contains every ball of radius
        ``r(s)`` centred on the path (``r`` interpolated linearly between points),
        through tapers, corners and caps (a flat cap then lies ``r`` beyond the end);
        radii that change faster than half the arc length are raised first (see
        :attr:`envelope_radii`).
    tolerance : float, optional
        Chordal tolerance used to choose ``sides``.
    frame : {"rmf", "patent"}
        Rotation-minimizing frames (default; no twist along a straight segment) or the
        source's ``OP x L`` rule (kept continuous; refused where ``OP`` is parallel to
        the path).
    normal : (3,) array_like, optional
        Direction of the first ring's vertex 0.
    end_normal : (3,) array_like, optional
        Direction the last ring's vertex 0 must take (up to the ring's symmetry, see
        :attr:`seam_shift`), e.g. to meet a flange; the twist is spread evenly. Open
        paths only.
    corners : {"miter", "round"}
        Polyline corners as miter joints (the rings meet in the bisector plane), or
        ball joints: the outside of each corner is the sphere of the corner's radius
        about the corner point, so the corner point keeps the full radius and no miter
        tip sticks out (the path itself is not rounded). With ``envelope=True`` the
        ball joint is a polyhedron circumscribing the ball of the corner's radius,
        united with the segments cut square there (conservative). Gentle corners keep
        their miter joint, which holds the corner's ball too.
    bend_radius : float, optional
        Deprecated: rounds the path itself with arcs of this radius (the pipe then
        follows :meth:`Path.fillet`'s path); pass ``path.fillet(bend_radius)[0]``.
    miter_limit : float
        Largest allowed stretch ``1/cos(turn/2)`` of a mitered ring (default 4, as SVG).
    cap_segments : int, optional
        Latitude steps of a round cap or ball joint (default ``max(2, sides // 4)``).
    strict : bool
        False (default): where the tube would overlap itself (a fold, a return, a
        corner beyond ``miter_limit``), :meth:`mesh` builds the swept solid there, the
        manifold3d union of that stretch's convex units (a corner beyond the miter
        limit becomes a ball joint); ``mesh().attributes["merged"]`` lists the merged
        stretches. True: raise :class:`GeometryError` naming the place instead.
    repair : bool, optional
        Deprecated alias: ``repair=True`` is the default, ``repair=False`` is
        ``strict=True``.
    """

    path: Path
    radius: float | np.ndarray
    sides: int | None = None
    _: KW_ONLY
    caps: str = "flat"
    envelope: bool = False
    tolerance: float | None = None
    frame: str = "rmf"
    normal: tuple[float, float, float] | None = None
    end_normal: tuple[float, float, float] | None = None
    corners: str = "miter"
    bend_radius: float | None = None
    miter_limit: float = 4.0
    cap_segments: int | None = None
    strict: bool = False
    repair: bool | None = None

    def __post_init__(self):
        set_ = partial(object.__setattr__, self)
        source = self.path if isinstance(self.path, Path) else Path(self.path)
        radius = as_positive(self.radius, "radius", count=len(source))
        caps = self.caps if isinstance(self.caps, (str, tuple, list)) else (self.caps,)
        caps = caps if isinstance(caps, str) else tuple(caps)
        if isinstance(caps, tuple) and len(caps) != 2:
            raise InputError(f"expected 'flat', 'round' or a (start, end) pair, got {caps!r}",
                             key="caps")
        set_("caps", as_choice(caps, "caps", CAP_STYLES) if isinstance(caps, str) else
             tuple(as_choice(c, "caps", CAP_STYLES) for c in caps))
        set_("frame", as_choice(self.frame, "frame", FRAME_MODES))
        set_("corners", as_choice(self.corners, "corners", CORNER_STYLES))
        set_("envelope", bool(self.envelope))
        if self.repair is not None:
            _deprecated.warn("Pipe(repair=...)", "the default (overlaps are merged into the "
                             "swept solid), or strict=True to refuse them", stacklevel=4)
            set_("strict", not self.repair)
            set_("repair", None)
        set_("strict", bool(self.strict))
        for name in ("normal", "end_normal"):
            value = getattr(self, name)
            set_(name, None if value is None else tuple(as_direction(value, name).tolist()))
        if self.envelope and self.frame == "patent":
            raise InputError("envelope=True needs the rotation-minimizing frame: the patent "
                             "frame twists the rings, and a twisted tube sags between them; "
                             "use frame='rmf'", key="frame")
        if self.end_normal is not None and source.closed:
            raise InputError("a closed path has no end: its last ring meets its first; "
                             "give only normal", key="end_normal")
        miter_limit = float(as_positive(self.miter_limit, "miter_limit"))
        if miter_limit < 1.0:
            raise InputError(f"must be >= 1, got {self.miter_limit}", key="miter_limit")
        set_("miter_limit", miter_limit)
        derived = self.sides is None and self.tolerance is not None
        set_("_sides_from_tolerance", derived)
        if self.tolerance is not None:
            set_("tolerance", float(as_positive(self.tolerance, "tolerance")))
        sides = self.sides
        if sides is None:
            sides = 16 if self.tolerance is None else \
                sides_for_tolerance(radius.max(), self.tolerance)
            if sides > MAX_SIDES:
                raise InputError(f"{self.tolerance:g} needs {sides} sides, more than "
                                 f"{MAX_SIDES}; use a larger tolerance", key="tolerance")
        set_("sides", as_int(sides, "sides", low=3, high=MAX_SIDES))
        if self.cap_segments is not None:
            set_("cap_segments", as_int(self.cap_segments, "cap_segments", low=1,
                                        high=MAX_SIDES))
        radii = np.broadcast_to(radius, (len(source),))
        if float(radii.min()) <= source._tolerance:
            raise InputError(f"{radii.min():g} is too small for this path, whose points "
                             f"closer than {source._tolerance:g} count as one; use a larger "
                             "radius", key="radius")
        if self.bend_radius is not None:
            warnings.warn("Pipe(bend_radius=...) rounds the path itself and is deprecated: "
                          "pass path.filleted(bend_radius) (corners='round' is now a ball "
                          "joint at each corner of the path as given)", DeprecationWarning,
                          stacklevel=3)
            bend = float(as_positive(self.bend_radius, "bend_radius"))
            filleted = source.filleted(bend)
            radii, source = _filleted_radii(source, bend, radii, filleted), filleted
            set_("bend_radius", None)
            set_("corners", "miter")
        set_("path", source)
        set_("radius", _frozen(radii) if radius.ndim else float(radius))

    def replace(self, **changes: Any) -> "Pipe":
        """This pipe with some settings changed.

        Parameters
        ----------
        **changes
            New values of the constructor's arguments; a ``sides`` that came from
            ``tolerance`` is chosen again unless given.

        Returns
        -------
        pipe : Pipe
        """
        if self._sides_from_tolerance and "sides" not in changes:
            changes["sides"] = None
        return dataclasses.replace(self, **changes)

    def __repr__(self):
        return (f"<cadpipe.Pipe {self.sides} sides, {len(self.path)} rings, "
                f"radius {self.radii.min():.6g}..{self.radii.max():.6g}>")

    @cached_property
    def radii(self) -> np.ndarray:
        """(N,) read-only tube radius at each path point."""
        return _frozen(np.broadcast_to(self.radius, (len(self.path),)))

    @cached_property
    def cap_steps(self) -> int:
        """Latitude steps of a round cap or ball joint: ``cap_segments`` or its default."""
        return max(2, self.sides // 4) if self.cap_segments is None else self.cap_segments

    def trimmed(self, start: float = 0.0, end: float = 0.0) -> "Pipe":
        """This pipe with ``start`` and ``end`` arc length cut off its ends (same settings).

        Parameters
        ----------
        start, end : float
            As for :meth:`Path.trimmed`.

        Returns
        -------
        pipe : Pipe
            Radii interpolated at the cuts.
        """
        path = self.path.trimmed(start, end)
        radii = np.interp(start + path.arc_length, self.path.arc_length, self.radii)
        return self.replace(path=path, radius=radii)

    @property
    def closed(self) -> bool:
        """Whether the path is closed (a ring of tube with no caps)."""
        return self.path.closed

    @cached_property
    def cap_styles(self) -> tuple[str, str]:
        """``caps`` as a (start, end) pair."""
        return (self.caps, self.caps) if isinstance(self.caps, str) else self.caps

    @cached_property
    def ring_radii(self) -> np.ndarray:
        """(N,) distance of ring vertices from the axis (before miter stretch).

        The radius itself, or with ``envelope=True`` (from :attr:`envelope_radii`) the
        circumradius of the polygon whose sides touch the widest section, in the ring's
        plane, of the round cones
        the balls of the segments beside it sweep: the ball's own radius, or where the
        segment tapers by ``a`` (``sin a = |dr| / length``) the cone's side line,
        ``r / cos(a)`` at the narrow end (while the cone's side starts before that end;
        else the wide ball's own section there). Then the faces are checked against
        the balls, and grown where a mitred ring on a taper or a twist leans them in
        (:meth:`_envelope_growth`).
        """
        if not self.envelope:
            return self.radii
        r = self.envelope_radii
        count = len(self.path.segments)
        lengths = self.path.segment_lengths
        near, far = r[:count], np.roll(r, -1)[:count]
        section = np.stack([_cone_section(far, near, lengths), _cone_section(near, far, lengths)])
        widest = np.ones((2, len(r)))
        widest[0, :count] = section[0] / near                     # each segment's start
        widest[1, (np.arange(count) + 1) % len(r)] = section[1] / far
        start = (r * envelope_factor(self.sides) * widest.max(axis=0)
                 / np.cos(self._twist_bound / 2))
        return _frozen(start * self._envelope_growth(start))

    @cached_property
    def envelope_radii(self) -> np.ndarray:
        """(N,) the radii an ``envelope=True`` pipe holds balls of: :attr:`radii`,
        raised where they change along the path by more than
        :data:`ENVELOPE_SLOPE` times the arc length (``max_i r_i - slope |s_i - s|``).
        A ball whose radius outruns its neighbours by more reaches past their rings
        and caps; the raised balls hold it, and their round cones are what the rings
        follow."""
        s, r = self.path.arc_length, self.radii
        if self.closed:                           # around the loop both ways: three laps
            s = np.concatenate([s - self.path.length, s, s + self.path.length])
            r = np.tile(r, 3)
        ahead = np.maximum.accumulate(r + ENVELOPE_SLOPE * s) - ENVELOPE_SLOPE * s
        behind = (np.maximum.accumulate((r - ENVELOPE_SLOPE * s)[::-1])[::-1]
                  + ENVELOPE_SLOPE * s)
        out = np.maximum(ahead, behind)
        return _frozen(out[len(self.path):2 * len(self.path)] if self.closed else out)

    def _envelope_growth(self, start):
        """(N,) how much the envelope's rings (``start``: radii from the taper and twist
        alone) must grow for every face to clear the balls it holds. A band's faces
        must lie at least ``r`` from the ball centres at both its rings (the balls
        between them are held by the cones' sections, see :attr:`ring_radii`); a mitred ring
        on a taper leans its faces towards the corner, a twisted band bends its quads
        in. Each band short of that grows both its rings, until none is
        (:data:`ENVELOPE_PASSES` at most). Distances are to the faces themselves,
        not their planes: a face that widens away from a ring leans its plane into
        that ring's ball, but not itself."""
        r = self.envelope_radii
        tubes = tubes_of([self], [start])
        centres = self.path.points
        first = np.arange(len(self.path.segments))
        second = (first + 1) % len(self.path)
        with np.errstate(invalid="ignore"):             # a reversal's ring: swept anyway
            offsets = tubes.rings(slice(None), self.sides) - centres[:, None]
        last = offsets[second]
        if self.closed:                                 # the seam meets ring 0 turned
            last[-1] = np.roll(last[-1], -tubes.seam_shift[0], axis=0)
        grow = np.ones(len(r))
        for _ in range(ENVELOPE_PASSES):
            faces = band_triangles(centres[first, None] + grow[first, None, None]
                                   * offsets[first], centres[second, None]
                                   + grow[second, None, None] * last)
            short = np.maximum(r[first] / clearance(faces, centres[first]),
                               r[second] / clearance(faces, centres[second]))
            # a band whose rings meet inside the tube is swept (its hull holds it)
            folded = local_folds(tubes.with_radii(start * grow))[0][first]
            short = np.where(np.isfinite(short) & (short > 0) & ~folded, short, 1.0)
            if (short <= 1 + 1e-12).all():
                break
            need = np.ones(len(r))
            np.maximum.at(need, first, short)
            np.maximum.at(need, second, short)
            grow *= need * (1 + 1e-9)
        return grow

    @cached_property
    def _twist_bound(self) -> float:
        """Most twist between neighbouring rings (radians): an end normal's is held to
        :data:`~cadpipe.geometry.frames.MAX_TWIST_STEP`, a loop's holonomy spreads at
        most ``pi / sides`` by arc length. A band twisted by ``d`` sags to
        ``cos(d / 2)`` of its radius, which an envelope makes up for."""
        if self.end_normal is not None:
            return MAX_TWIST_STEP
        if self.closed:
            return np.pi / self.sides * float(self.path.segment_lengths.max()) / self.path.length
        return 0.0

    @cached_property
    def cap_reach(self) -> tuple[float, float]:
        """How far the solid reaches past the path's first and last point, along it."""
        if self.closed:
            return (0.0, 0.0)
        return tuple(_cap_reach(self, style, sign)
                     for style, sign in zip(self.cap_styles, (-1, 1)))

    @cached_property
    def _tubes(self):
        return tubes_of([self])

    @property
    def normals(self) -> np.ndarray:
        """(N, 3) unit direction of each ring's vertex 0 (before miter stretch)."""
        return np.ascontiguousarray(self._tubes.normals.T)

    @property
    def binormals(self) -> np.ndarray:
        """(N, 3) unit ``tangent x normal`` at each ring."""
        return cross(self.path.tangents, self.normals)

    @property
    def seam_shift(self) -> int:
        """The last ring's vertex k meets vertex k + shift of the ring it must match: the
        first ring of a closed pipe, or the ring that ``end_normal`` describes."""
        return int(self._tubes.seam_shift[0])

    @property
    def miter_stretch(self) -> np.ndarray:
        """(N,) factor ``1 / cos(turn / 2)`` by which each ring is stretched in its bend plane."""
        return self._tubes.miter_stretch

    def ring_axes(self) -> np.ndarray:
        """(N, 2, 3) vectors that map ``(cos a, sin a)`` to a ring vertex offset.

        Returns
        -------
        axes : (N, 2, 3) float

        Each ring is the circle of ``ring_radii`` in the plane normal to the
        tangent, stretched by :attr:`miter_stretch` along the bend direction so that
        it lies on both adjacent segments' cylinders.
        """
        return self._tubes.axes[:, :2]

    def rings(self, sides: int | None = None) -> np.ndarray:
        """Ring vertices, counter-clockwise about the tangent.

        Parameters
        ----------
        sides : int, optional
            Vertices per ring, by default the pipe's own; rings of other sizes on the
            same frames are what a splice's transitions are made of.

        Returns
        -------
        rings : (N, sides, 3) float
        """
        return self._tubes.rings(slice(None), self.sides if sides is None else sides)

    @property
    def attributes(self) -> Mapping[str, Any]:
        """Read-only mapping of the parameters that made this pipe, for exporters' metadata."""
        return _deprecated.Attributes({
            "kind": "pipe", "sides": self.sides, "radius_min": float(self.radii.min()),
            "radius_max": float(self.radii.max()), "path_length": self.path.length,
            "path_points": len(self.path), "closed": self.closed,
            "caps": "/".join(dict.fromkeys(self.cap_styles)),
            "envelope": self.envelope, "frame": self.frame, "corners": self.corners},
            "Pipe.attributes")

    # -- checks and mesh -----------------------------------------------------
    def folds(self) -> "Folds":
        """Where the tube would cut through itself.

        Checks, cheapest first, miter limits, rings that overlap within a segment
        (the radius exceeds the local bend radius) and stretches apart along the
        path that come closer than the tube reaches there, miter tips included.

        Returns
        -------
        folds : Folds
            False when the tube is clean; else its findings and the segments a union
            merges (:class:`~cadpipe.geometry.clearance.Folds`).
        """
        return self._folds()

    def _folds(self, first_only=False):
        """:meth:`folds`; with ``first_only`` the checks stop at the first kind that
        finds anything (all a refusal needs)."""
        folds = self._tubes.folds(first_only=first_only)[0]
        if folds and first_only:
            return folds
        return self._with_cap_folds(folds)

    def _with_cap_folds(self, folds, ends=(True, True)):
        """``folds`` (of this pipe's tube) with those of its end caps where ``ends``
        (start, end) has one: where a cap (round, or an envelope's flat cap reaching
        ``r`` past the end) overlaps the unit of a segment other than its own, the
        findings, and the cap's segment and those it reaches to merge. A splice
        cuts a pipe's ends that meet transitions: they have no cap."""
        ends = tuple(bool(e) for e in ends)
        cache = self.__dict__.setdefault("_cap_folds_of", {})     # per pipe, as cached_property
        if ends not in cache:
            cache[ends] = self._cap_folds(ends)
        messages, segments = cache[ends]
        if not messages:
            return folds
        return Folds(folds.messages + messages, np.union1d(folds.segments, segments),
                     folds.joints)

    def _cap_folds(self, ends):
        empty = ((), np.empty(0, np.int64))
        count = len(self.path.segments)
        # only a round cap, or an envelope's flat one, reaches past its end ring
        reaching = [e and (style == "round" or self.envelope)
                    for e, style in zip(ends, self.cap_styles)]
        if self.closed or count < 2 or not any(reaching):
            return empty
        tubes, lines = self._tubes, self._tubes.lines
        r = reach(tubes)
        reach_seg = np.maximum(r[:-1], r[1:])
        messages, merged = [], []
        for row, sign, seg, style, name, wanted in (
                (0, -1, 0, self.cap_styles[0], "start", ends[0]),
                (count, 1, count - 1, self.cap_styles[1], "end", ends[1])):
            cap = cap_axes(tubes, row, sign, self, style) if wanted else None
            if cap is None:
                continue
            points = np.concatenate([self.rings()[row],
                                     np.matmul(ring_basis(self.sides), cap[0]).reshape(-1, 3),
                                     np.empty((0, 3)) if cap[1] is None else cap[1][None]])
            centre = points.mean(axis=0)
            size = float(np.linalg.norm(points - centre, axis=1).max())
            cols = np.delete(np.arange(count), seg)
            gap = segment_distance(np.broadcast_to(centre[:, None], (3, len(cols))),
                                   np.zeros((3, len(cols))), lines.xyz[:, cols],
                                   lines.segments[:, cols])
            cols = cols[gap < size + reach_seg[cols]]
            hit = cols[piece_meets_units(tubes, points, cols)]
            if hit.size:
                k = int(hit[0])
                messages.append(
                    f"the {name} cap (caps={style!r}{', envelope=True' if self.envelope else ''}"
                    f") reaches the tube between path points {k} and {k + 1} (arc length "
                    f"{self.path.arc_length[k]:.6g}); lengthen the {name} segment or reduce "
                    "the radius" + (", or use caps='flat'" if style == "round" else ""))
                merged += [seg, *hit.tolist()]
        return tuple(messages), np.unique(np.asarray(merged, np.int64))

    def self_intersection_findings(self) -> list[str]:
        """Where the tube would cut through itself.

        Returns
        -------
        findings : list of str
            Empty for a tube that does not cut through itself.
        """
        return list(self.folds().messages)

    def self_intersections(self) -> list[str]:
        """Deprecated: :meth:`self_intersection_findings`."""
        _deprecated.warn("Pipe.self_intersections()", "Pipe.self_intersection_findings()")
        return self.self_intersection_findings()

    def mesh(self) -> Mesh:
        """The closed, outward-oriented, watertight triangle mesh of this pipe.

        Returns
        -------
        mesh : Mesh
            The tube, or where it would overlap itself the swept solid.

        A clean tube is its rings stitched together. Where it would overlap itself the
        result is the swept solid instead (see ``strict``): the clean stretches as
        they are, united through manifold3d with the convex units of the stretches
        that overlap; ``attributes["merged"]`` names them. With ``strict=True`` such a
        tube raises :class:`GeometryError` naming the place.
        """
        self._require_float32()
        folds = self._folds(first_only=self.strict)
        if not folds and not self._united_joints:
            surface = self._laid_out(not self.closed, not self.closed)
            vertices, faces, _ = surface.build()
            # the ring runs let writers take the side normals from the rings (io.normals)
            return Mesh.trusted(vertices, faces, attributes=self.attributes,
                                ring_runs=surface.ring_runs)
        if folds and self.strict:
            problems = folds.messages
            more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
            raise GeometryError(f"the pipe intersects itself: {problems[0]}{more}; smooth the "
                                "path, reduce the radius, or build the swept solid instead",
                                fix={"strict": False})
        limits.check("max_swept_segments", len(folds.segments),
                     "the swept solid of a tube whose path comes back within its own reach "
                     "(segments to merge)",
                     key="path")
        return self._swept_mesh(folds)

    def _require_float32(self):
        """Refuse a tube finer than float32 coordinates resolve at its distance from the
        origin: STL, 3MF, OBJ, PLY and GLB files would weld its rings shut (rings closer
        than that along the path merge into one, which leaves a valid surface)."""
        edge = 2 * float(self.ring_radii.min()) * np.sin(np.pi / self.sides)
        largest = float(np.abs(self.path.points).max()) + float(self.ring_radii.max())
        step = FLOAT32_STEPS * float(np.finfo(np.float32).eps) * largest
        if edge < step:
            raise GeometryError(
                f"the tube's ring edges ({edge:.3g} long) are finer than float32 files can "
                f"hold {largest:.3g} from the origin (steps of {step:.3g} there); move the "
                "path nearer the origin or use a larger radius", key="radius")

    def surface(self, *, cap_start: bool = True,
                cap_end: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Vertices and faces of the side surface plus the requested end caps.

        Vertices are the rings in travel order (a round start cap's rings first, a
        round end cap's last), then the caps' poles. Without a cap, the first or last
        ``sides`` vertices are that end's open ring: a splice stitches it to the next
        piece.

        Parameters
        ----------
        cap_start, cap_end : bool
            Close that end (ignored on a closed path).

        Returns
        -------
        vertices : (V, 3) float
        faces : (F, 3) int
        """
        vertices, faces, _ = self._laid_out(cap_start, cap_end).build()
        return vertices, faces

    def _laid_out(self, cap_start, cap_end):
        """The :class:`Surface` of :meth:`surface`, before it is built."""
        surface = Surface()
        add_pipe_surfaces(surface, self._tubes, [self], cap_start=[cap_start], cap_end=[cap_end])
        return surface

    def units(self, overlap: float = 0.0) -> list[np.ndarray]:
        """Deprecated: :meth:`convex_pieces` (``units`` is a length unit elsewhere)."""
        _deprecated.warn("Pipe.units()", "Pipe.convex_pieces()")
        return self.convex_pieces(overlap)

    def convex_pieces(self, overlap: float = 0.0) -> list[np.ndarray]:
        """Convex pieces whose union is the tube: each path unit, ball joints, round caps.

        Parameters
        ----------
        overlap : float
            How far each unit's rings are pushed outward along its segment, in path
            units (see below).

        Returns
        -------
        pieces : list of (K, 3) float
            The points whose convex hull is each piece.

        Each unit is the point set of two consecutive rings (their convex hull is the
        unit); at a ball joint (``corners="round"``) the units are cut square at the
        corner and a ball holds it; a cap is its end ring and the cap's rings and pole.
        ``overlap`` pushes each unit's rings that far outward along its segment, so that
        neighbouring units overlap instead of merely touching (booleans treat touching
        solids as apart). The swept solid is built from these same pieces.
        """
        rows = np.flatnonzero(round_corner_rows(self._tubes, 0, len(self.path) - 1, self))
        return _units(self, np.arange(len(self.path.segments)), rows, overlap=overlap)

    def collision_units(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Round cones whose union contains this pipe's mesh: the collision model.

        Built from the convex pieces :meth:`mesh` is made of (see
        :mod:`cadpipe.geometry.cover`), swept stretches included: per segment (or run
        of segments merged into one hull) a cone between its end rings' centres, its
        radii grown by whatever of the piece sticks out of them (a taper leaning into
        a mitred ring); per mitred corner a capsule from the corner point towards the
        miter tip; per ball (a joint, a corner beyond the miter limit) and round cap a
        ball; per envelope flat cap a capsule to the cap's face.

        The chain contains the mesh (every vertex, and every face: each piece is convex
        and inside its units). Each unit's axis lies inside the mesh, so the chain
        exceeds the mesh by at most that unit's radius (the ring radius ``rho``, grown
        where a piece sticks out of it): that far only past flat caps, where the units
        end in balls; elsewhere by the polygon's chordal deviation ``rho (1 - cos(pi /
        sides))`` along straight stretches, about ``0.3 rho`` at the outside of a
        right-angled miter, 4 % of ``rho`` at a swept ball.

        Returns
        -------
        starts, ends : (U, 3) float
        start_radii, end_radii : (U,) float
        """
        count = len(self.path.segments)
        folds = self._folds()
        merged, joints = self._swept_plan(folds) if folds or self._united_joints else (
            np.zeros(count, bool), np.empty(0, np.int64))
        units = [_segment_covers(self, np.flatnonzero(~merged))]
        if merged.any():
            units.append(_piece_covers(_unit_pieces(self, np.flatnonzero(merged), joints,
                                                    tongue=TONGUE)))
        return tuple(np.concatenate([u[k] for u in units]) for k in range(4))

    @cached_property
    def _united_joints(self):
        """Whether the mesh unites ball joints with their segments even where the tube
        does not fold: an envelope's round corners (see :func:`joint_rows_of`)."""
        return self.envelope and bool(round_corner_rows(self._tubes, 0, len(self.path) - 1,
                                                        self).any())

    def _swept_mesh(self, folds):
        """The tube with each stretch that folds (and each envelope ball joint)
        replaced by the union of its convex units, as one welded mesh (see
        :meth:`_swept_solid` and :func:`welded_solid`); where it folds,
        ``attributes["merged"]`` names the merged stretches."""
        solid, stretches = self._swept_solid(folds)
        if not folds:
            return welded_solid(solid, attributes=self.attributes)
        arc = self.path.arc_length
        spans = [(float(arc[a]), float(arc[(b + 1) % len(arc)] if b + 1 < len(arc)
                                     else self.path.length)) for a, b in stretches]
        names = "; ".join(f"path points {a}..{(b + 1) % len(arc)} (arc length {s:.6g} to "
                          f"{e:.6g})" for (a, b), (s, e) in zip(stretches, spans))
        return welded_solid(solid, attributes={
            **self.attributes, "merged": names,
            "merged_arc_lengths": tuple(x for span in spans for x in span),
            "folds": folds.messages[0]})

    def _swept_solid(self, folds, ends=(True, True)):
        """The tube with each stretch that folds replaced by the union of its convex
        units (:func:`_units`), the clean stretches kept as they are, all united by
        manifold3d.

        Inside a merged stretch every corner beyond the miter limit, and every ball
        joint, is a ball with the units cut square at it; a stretch is widened until
        it ends on plain rings, so a clean piece never ends on a joint.

        Parameters
        ----------
        folds : Folds
            Where the tube folds (:meth:`folds`, or :meth:`_with_cap_folds` for the
            same ``ends``).
        ends : (bool, bool)
            Whether the start and end keep their caps; False cuts that end flat on its
            last ring (where a splice's transition continues it).

        Returns
        -------
        solid : manifold3d.Manifold
        stretches : list of (int, int)
            The merged segments' runs, first and last segment (wrapping around a
            closed pipe).
        """
        import manifold3d

        merged, joints = self._swept_plan(folds)
        # manifold3d's tolerance grows with the coordinates: unite about the pipe's middle
        low, high = self.path.points.min(axis=0), self.path.points.max(axis=0)
        middle = 0.5 * (low + high)
        pieces = _units(self, np.flatnonzero(merged), joints, tongue=TONGUE, capped=ends)
        solids = [hull_solid(p - middle) for p in pieces]
        if not merged.all():
            for a, b in _runs(~merged, self.closed):
                piece = self._piece(a, b, ends)
                solids.append(Mesh.trusted(piece.vertices - middle, piece.faces)
                              .to_manifold("pipe"))
        solid = manifold3d.Manifold.batch_boolean(solids, manifold3d.OpType.Add)
        return solid.translate(tuple(middle.tolist())), _runs(merged, self.closed)

    def _swept_plan(self, folds):
        """``(merged, joints)``: (M,) which segments the swept solid builds from their
        convex units, and the corners inside them that are balls (beyond the miter
        limit, reversals, ball joints), the merged stretches widened until they end on
        plain rings. An envelope's round corners are always balls (see
        :func:`joint_rows_of`), so the segments beside them are always merged."""
        n, count = len(self.path), len(self.path.segments)
        merged = np.zeros(count, bool)
        merged[folds.segments] = True
        rows = np.arange(n)
        before = np.where(rows > 0, rows - 1, count - 1 if self.closed else -1)
        after = np.where(rows < count, rows, -1)
        corner = (before >= 0) & (after >= 0)
        round_ = corner & round_corner_rows(self._tubes, 0, n - 1, self)
        ball = round_ | (corner & self._tubes.over_limit)
        ball[folds.joints] = True
        if self.envelope:
            merged[before[round_]] = merged[after[round_]] = True
        while True:                         # widen stretches that end on a ball joint
            touched = ball & (merged[before] | merged[after]) & ~(merged[before]
                                                                  & merged[after])
            if not touched.any():
                break
            merged[before[touched]] = merged[after[touched]] = True
        return merged, np.flatnonzero(ball & merged[before] & merged[after])

    def _piece(self, first, last, ends=(True, True)):
        """The closed solid of the clean segments ``first..last`` (wrapping around a
        closed pipe): laid out by :func:`add_pipe_surfaces` as the whole pipe is, with
        flat fans where the stretch is cut (and at ends ``ends`` leaves without cap)."""
        surface = Surface()
        add_pipe_surfaces(surface, self._tubes, [self], cap_start=[True], cap_end=[True],
                          windows=[(first, last)], cut=[(not ends[0], not ends[1])])
        vertices, faces, _ = surface.build()
        return Mesh.trusted(vertices, faces)


#: most an envelope's radii change per unit of arc length (see Pipe.envelope_radii)
ENVELOPE_SLOPE = 0.5
#: most passes of growing an envelope's rings until its faces clear its balls
ENVELOPE_PASSES = 8
#: merged units reach this fraction of the ring radius into their neighbours (see _units)
TONGUE = 1e-3


def hull_solid(points, name="hull", original_id=None):
    """The convex hull of ``points`` (K, 3) as a manifold3d solid, triangulated by qhull.

    manifold3d's own ``hull_points`` leaves folded triangles where many points are
    coplanar (two parallel rings, two equal balls side by side: 12 crossing face pairs
    on a splice's ball joint); qhull's triangulation of a coplanar facet is flat."""
    from scipy.spatial import ConvexHull

    hull = ConvexHull(points)
    faces = hull.simplices.copy()
    tri = points[faces]
    inward = np.einsum("ij,ij->i", np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                       hull.equations[:, :3]) < 0
    faces[inward] = faces[inward][:, ::-1]
    used, local = np.unique(faces, return_inverse=True)
    return Mesh.trusted(points[used], local.reshape(-1, 3)).to_manifold(name, original_id)


def welded_solid(solid, part_of_id=None, **kwargs):
    """The :class:`Mesh` of a manifold3d ``solid`` (faces labelled by ``part_of_id`` as
    :meth:`Mesh.from_manifold` does), with no two vertices closer than float32 can tell
    apart at its size.

    A union leaves clusters of vertices where its pieces meet at grazing angles; STL,
    3MF, OBJ and PLY files (float32) would merge them, into edges shared by more than
    two faces. A solid with vertices closer than :data:`FLOAT32_CLOSE` units in the
    last place of its largest coordinate is simplified by manifold3d's own edge
    collapses (:data:`FLOAT32_WELD`) and its clusters merged; a weld that changes the
    volume, leaves an open or badly wound surface, or folds a sliver through a face is
    not taken, and smaller distances are tried, down to :data:`FLOAT32_CLOSE` units;
    failing all, the float64 solid as manifold3d made it.
    """
    from scipy.spatial import cKDTree

    if solid.is_empty():
        raise GeometryError("the swept solid is empty")
    low, high = np.asarray(solid.bounding_box()).reshape(2, 3)
    ulp = 2.0 ** -23 * max(float(np.abs(np.concatenate([low, high])).max()), 1e-30)
    volume = solid.volume()
    plain = Mesh.from_manifold(solid, part_of_id, **kwargs)
    if not len(cKDTree(plain.vertices).query_pairs(FLOAT32_CLOSE * ulp,
                                                   output_type="ndarray")):
        return plain                                 # nothing a float32 file would merge
    for ulps in (FLOAT32_WELD, 4, FLOAT32_CLOSE):
        welded = _weld(plain, ulps * ulp)
        if welded is not None and abs(welded[0].volume - volume) <= WELD_VOLUME * volume \
                and not _crossings_near(*welded, ulps * ulp):
            return welded[0]
    return plain


def _crossings_near(mesh, moved, shift):
    """Whether a face of ``mesh`` that the weld ``moved`` ((F,) bool, each point by at
    most ``shift``) cuts through another face. The rest is manifold3d's surface as it
    made it, which does not, so only faces whose boxes come within ``shift`` of a moved
    face's box are tested."""
    from cadpipe.solids.intersect import self_intersections

    if not moved.any():
        return False
    tri = mesh.triangles
    low, high = tri.min(axis=1), tri.max(axis=1)
    near = moved.copy()
    for rows in np.array_split(np.flatnonzero(moved), max(1, int(moved.sum()) // 256)):
        near |= ((low[None] <= high[rows, None] + shift)
                 & (high[None] >= low[rows, None] - shift)).all(axis=2).any(axis=0)
    return bool(len(self_intersections(Mesh.trusted(mesh.vertices, mesh.faces[near]))))


def _weld(mesh, tol):
    """``mesh`` with its vertex clusters closer than ``tol`` merged (its parts and
    attributes kept) and (F,) which of its faces moved, or None if that does not leave
    a closed, oriented surface."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    vertices, faces = mesh.vertices, mesh.faces
    pairs = cKDTree(vertices).query_pairs(tol, output_type="ndarray")
    if not len(pairs):
        return (mesh, np.zeros(len(faces), bool)) if len(faces) and mesh.is_oriented else None
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(len(vertices), len(vertices)))
    count, label = connected_components(graph, directed=False)
    faces = label[faces]
    keep = ((faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2])
            & (faces[:, 2] != faces[:, 0]))
    merged = np.empty((count, 3))
    merged[label] = vertices
    faces = faces[keep]
    # sheets that touched along faces: such a face now comes twice, facing both ways
    _, index, counts = np.unique(np.sort(faces, axis=1), axis=0, return_inverse=True,
                                 return_counts=True)
    single = counts[index.reshape(-1)] == 1
    faces = faces[single]
    moved = (np.bincount(label, minlength=count) > 1)[faces].any(axis=1)
    used, faces = np.unique(faces, return_inverse=True)
    part = None if mesh.face_part is None else mesh.face_part[keep][single]
    welded = Mesh(merged[used], faces.reshape(-1, 3), face_part=part,
                  part_names=mesh.part_names if part is not None else (),
                  attributes=mesh.attributes)
    return (welded, moved) if len(faces) and welded.is_oriented else None


#: weld distance, in units in float32's last place (2**-23) of the largest coordinate
FLOAT32_WELD = 16
#: vertices closer than this (units in the last place) may round to one float32 point
FLOAT32_CLOSE = 2
#: features shorter than this many float32 steps at the largest coordinate are refused
FLOAT32_STEPS = 1
#: a weld may change the volume by this fraction at most (else the solid was too fine)
WELD_VOLUME = 1e-3


def _runs(mask, closed):
    """``[(first, last)]`` index ranges of the runs of True in ``mask``; around a closed
    pipe a run may wrap (``last < first``)."""
    n = len(mask)
    if mask.all():
        return [(0, n - 1)]
    shift = int(np.argmin(mask)) + 1 if closed else 0        # start just after a False
    rolled = np.roll(mask, -shift)
    edges = np.diff(np.concatenate([[0], rolled.astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [((a + shift) % n, (b + shift) % n) for a, b in zip(starts.tolist(), stops.tolist())]


def _units(pipe, segments, joints, overlap=0.0, tongue=0.0, capped=(True, True)):
    """Point sets whose convex hulls together make the tube along ``segments``: the
    points of each :func:`_unit_pieces` piece."""
    return [piece.points for piece in _unit_pieces(pipe, segments, joints, overlap, tongue,
                                                   capped)]


@dataclass(frozen=True)
class _Piece:
    """A convex piece of a tube: the hull of ``points`` (K, 3), along the spine ``a ->
    b`` whose rings nominally have radii ``ra``, ``rb``; past an end it leans out
    towards that end's ``tip`` (a mitred corner's; the end itself elsewhere). See
    :func:`~cadpipe.geometry.cover.round_cone_covers`."""

    points: np.ndarray
    a: np.ndarray
    b: np.ndarray
    ra: float
    rb: float
    tip_a: np.ndarray
    tip_b: np.ndarray


def _unit_pieces(pipe, segments, joints, overlap=0.0, tongue=0.0, capped=(True, True)):
    """The convex pieces (:class:`_Piece`) that together make the tube along ``segments``.

    Each segment's unit is its two end rings (a run of nearly straight segments one
    hull of their rings, see :func:`_hull_groups`); at a corner in ``joints`` (beyond
    the miter limit, or a ball joint) the rings there are cut square to the segment
    instead and a ball (:func:`_ball`) holds the corner. Caps of an open pipe join the
    units of its end segments (at the ends ``capped`` says keep them). Where another
    segment continues a unit, its ring there is pushed ``overlap`` along the unit's own
    segment, and a ``tongue`` (a fraction of the ring radius) adds the ring shrunk by
    that fraction and moved as far into the next segment: the hulls then cross their
    neighbours at steep angles instead of sharing a face (manifold3d may leave a shared
    face's corners doubled).
    """
    path = pipe.path
    with np.errstate(invalid="ignore"):             # a reversal's ring: not used (a joint)
        rings = pipe.rings()
    n, count = len(path), len(path.segments)
    joints = np.asarray(joints, np.int64)
    at_joint = np.zeros(n, bool)
    at_joint[joints] = True
    directions, centres, lengths = path.directions, path.points, path.segment_lengths
    radii = pipe.ring_radii
    tips = np.where(at_joint[:, None], centres, _miter_tips(pipe))

    def into(p, seg, sign):
        """Ring ``p`` shrunk and moved into segment ``seg`` (``sign``: along or back)."""
        step = min(tongue * float(radii[p]), 0.25 * float(lengths[seg]))
        return centres[p] + (1 - tongue) * (rings[p] - centres[p]) + sign * step * directions[seg]

    def square(k, p):
        """Segment k's cross-section at its end ``p`` (a joint): the prism's section,
        from its other end's ring, or a fresh polygon when both ends are joints."""
        q = (k + 1) % n if p == k else k
        d = directions[k]
        if at_joint[q]:
            return square_rings(centres[p][None], d[None], radii[p:p + 1], pipe.sides)[0]
        offsets = rings[q] - centres[q]
        offsets = (offsets - (offsets @ d)[:, None] * d) * (float(radii[p]) / float(radii[q]))
        return centres[p] + offsets

    pieces = []
    for first, last in _hull_groups(pipe, segments, at_joint):
        ends = []
        for k, p, sign, other in ((first, first, -1.0, first - 1),
                                  (last, (last + 1) % n, 1.0, last + 1)):
            ring = rings[p]
            inner = pipe.closed or 0 <= other < count
            if at_joint[p]:
                ring = square(k, p)
            elif inner and tongue:
                ends.append(into(p, other % count, sign))
            ends.append(ring + (sign * overlap * inner) * directions[k])
        ends.insert(len(ends) // 2, rings[first + 1:last + 1].reshape(-1, 3))
        a, b = first, (last + 1) % n
        pieces.append(_Piece(np.concatenate(ends), centres[a], centres[b], float(radii[a]),
                             float(radii[b]), tips[a], tips[b]))
    # an envelope's ball circumscribes the ball of the path's radius (its rings, those
    # of the polygon circumscribing that ball's sections, are wider)
    ball_radii = pipe.envelope_radii if pipe.envelope else radii
    for k in joints.tolist():
        pieces.append(_Piece(_ball(centres[k], float(ball_radii[k])), centres[k], centres[k],
                             0.0, 0.0, centres[k], centres[k]))
    if not pipe.closed:
        for row, sign, seg, style, wanted in ((0, -1, 0, pipe.cap_styles[0], capped[0]),
                                              (n - 1, 1, count - 1, pipe.cap_styles[1], capped[1])):
            end_cap = cap_axes(pipe._tubes, row, sign, pipe, style) if wanted else None
            if end_cap is not None and seg in set(np.asarray(segments).tolist()):
                inside = into(row, seg, -sign) if tongue else rings[row] - (
                    sign * overlap) * directions[seg]
                pieces.append(_cap_piece(pipe, row, end_cap, [rings[row], inside]))
    return pieces


def _cap_piece(pipe, row, cap, rings):
    """The :class:`_Piece` of an end cap (``cap`` as :func:`cap_axes` gives it) closing
    ``rings`` at path point ``row``: a round cap is held by a ball about the end, an
    envelope's flat cap by the capsule to its face."""
    axes, pole = cap
    end = pipe.path.points[row]
    points = np.concatenate([*rings, np.matmul(ring_basis(pipe.sides), axes).reshape(-1, 3),
                             np.empty((0, 3)) if pole is None else pole[None]])
    face = end if pole is not None else axes[0, 2]
    radius = float(pipe.ring_radii[row])
    return _Piece(points, end, face, radius, radius, end, face)


def _miter_tips(pipe):
    """(N, 3) how far a capsule of the ring radius must run out from each corner point
    to hold its mitred ring's outside: ``(stretch - 1) rho`` outwards in the bend plane
    (the ring reaches ``stretch * rho``), but no farther than ``stretch * rho *
    cos(pi / sides)``, which the ring's polygon always reaches, so the capsule's axis
    stays inside the tube (the corner point itself where the path runs straight,
    reverses or ends)."""
    stretch = pipe.miter_stretch
    lean = np.where(np.isfinite(stretch), np.minimum(stretch - 1.0, stretch * np.cos(
        np.pi / pipe.sides)), 0.0) * pipe.ring_radii
    return pipe.path.points - lean[:, None] * pipe.path.bend_directions


def _segment_covers(pipe, segments):
    """The collision units (starts, ends, start radii, end radii) of the plain tube along
    ``segments`` (laid out as :meth:`Pipe.surface` lays it out): each segment's unit,
    the capsules of its mitred corners, its ball joints and the caps of its ends."""
    n = len(pipe.path)
    empty = (np.empty((0, 3)), np.empty((0, 3)), np.empty(0), np.empty(0))
    if not len(segments):
        return empty
    centres, radii = pipe.path.points, pipe.ring_radii
    start_ring, end_ring, joints = laid_rings(pipe)
    tips = _miter_tips(pipe)
    joint_units = []
    for row, (outer, swept) in joints.items():
        tips[row] = centres[row]
        reach_ = float(np.linalg.norm(swept[:, outer] - centres[row], axis=2).max())
        joint_units.append((centres[row], centres[row], reach_, reach_))
    a, b = np.asarray(segments), (np.asarray(segments) + 1) % n
    wedge = np.zeros(n)
    need = np.zeros(n, bool)
    cones = []
    for rows in np.array_split(np.arange(len(a)), max(1, len(a) // COVER_BLOCK)):
        ka, kb = a[rows], b[rows]
        cone, before, past = round_cone_covers(
            np.concatenate([start_ring[ka], end_ring[kb]], axis=1), centres[ka], centres[kb],
            radii[ka], radii[kb], tips[ka], tips[kb])
        cones.append(cone)
        for at, (_, radius, needed) in ((ka, before), (kb, past)):
            np.maximum.at(wedge, at, np.where(needed, radius, 0.0))
            need[at] |= needed
    corner = np.flatnonzero(need)
    units = [tuple(np.concatenate([c[k] for c in cones]) for k in range(4)),
             (centres[corner], tips[corner], wedge[corner], wedge[corner])]
    if joint_units:
        units.append(tuple(np.array(v) for v in zip(*joint_units)))
    if not pipe.closed:
        caps = []
        for row, sign, seg, style in ((0, -1, 0, pipe.cap_styles[0]),
                                      (n - 1, 1, len(pipe.path.segments) - 1,
                                       pipe.cap_styles[1])):
            cap = cap_axes(pipe._tubes, row, sign, pipe, style)
            if cap is not None and seg in set(np.asarray(segments).tolist()):
                caps.append(_cap_piece(pipe, row, cap, [end_ring[row]]))
        if caps:
            units.append(_piece_covers(caps))
    return tuple(np.concatenate([u[k] for u in units]) for k in range(4))


def laid_rings(pipe):
    """The rings the plain tube's side is laid out on, as :meth:`Pipe.surface` lays it
    out: ``(starts, ends, joints)``, (N, sides, 3) the ring each segment leaves from
    and the one it arrives at (the ring itself, or at a ball joint the joint's last and
    first ring), and ``{row: (outer, rings)}`` each ball joint (:func:`_joint`)."""
    with np.errstate(invalid="ignore"):             # a reversal's ring: not used (a joint)
        rings = pipe.rings()
    starts, ends = rings.copy(), rings
    joints = {}
    for row in np.flatnonzero(joint_rows_of(pipe._tubes, 0, len(pipe.path) - 1, pipe)).tolist():
        joints[row] = _joint(pipe._tubes, row, pipe)
        ends[row], starts[row] = joints[row][1][0], joints[row][1][-1]
    return starts, ends, joints


def _piece_covers(pieces):
    """The collision units of convex pieces (:class:`_Piece`): their round cone covers
    (:func:`~cadpipe.geometry.cover.round_cone_covers`), one piece at a time."""
    units = []
    for piece in pieces:
        cone, before, past = round_cone_covers(
            piece.points[None], piece.a[None], piece.b[None], np.array([piece.ra]),
            np.array([piece.rb]), piece.tip_a[None], piece.tip_b[None])
        units.append(cone)
        for centre, (tip, radius, needed) in ((piece.a, before), (piece.b, past)):
            if needed[0]:
                units.append((centre[None], tip, radius, radius))
    return tuple(np.concatenate([u[k] for u in units]) for k in range(4))


#: segments whose covers are computed at once (bounds the memory of their points)
COVER_BLOCK = 4096


def _hull_groups(pipe, segments, at_joint):
    """``[(first, last)]``: the sorted ``segments`` in runs whose units one convex hull
    may replace, because the path between them strays from its chord by at most half
    the ring polygon's own chordal deviation (the hull fills the inside of a bend by
    about that much). A joint ends a run. With a radius far larger than the bends, a
    whole stretch is one hull instead of hundreds of nearly equal ones."""
    points, radii = pipe.path.points, pipe.ring_radii
    slack = 0.5 * (1 - np.cos(np.pi / pipe.sides))
    groups = []
    for k in np.asarray(segments).tolist():
        if groups and groups[-1][1] == k - 1 and not at_joint[k] and k + 1 < len(points):
            first = groups[-1][0]
            chord = points[k + 1] - points[first]
            inner = points[first + 1:k + 1] - points[first]
            along = np.clip(inner @ chord / max(float(chord @ chord), 1e-300), 0, 1)
            stray = np.linalg.norm(inner - along[:, None] * chord, axis=1).max()
            if stray <= slack * float(radii[first:k + 2].min()):
                groups[-1] = (first, k)
                continue
        groups.append((k, k))
    return groups


def _ball(centre, radius):
    """(P, 3) points whose convex hull contains the ball of ``radius`` about ``centre``
    with a margin (:data:`~cadpipe.geometry.clearance.BALL_REACH`): a latitude-longitude
    sphere whose faces all lie beyond the ball."""
    lon = 2 * np.pi * np.arange(BALL_SIDES) / BALL_SIDES
    lat = np.pi * (np.arange(1, BALL_SIDES // 2) / (BALL_SIDES // 2) - 0.5)
    ring = np.stack([np.cos(lat)[:, None] * np.cos(lon), np.cos(lat)[:, None] * np.sin(lon),
                     np.broadcast_to(np.sin(lat)[:, None], (len(lat), len(lon)))], -1)
    unit = np.concatenate([ring.reshape(-1, 3), [[0, 0, -1], [0, 0, 1]]])
    return centre + (BALL_REACH * radius) * unit


def tubes_of(pipes, ring_radii=None):
    """The pipes' rings, frames and checks as one :class:`~cadpipe.geometry.rings.Tubes`
    batch (``ring_radii``: per pipe, instead of their own)."""
    return Tubes(polylines([p.path for p in pipes]),
                 np.concatenate([p.ring_radii for p in pipes] if ring_radii is None
                                else ring_radii),
                 [p.sides for p in pipes],
                 [p.miter_limit if p.corners == "miter" else np.inf for p in pipes],
                 patent=[p.frame == "patent" for p in pipes],
                 normals=np.array([as_direction(p.normal, "normal") for p in pipes]),
                 end_normals=np.array([as_direction(p.end_normal, "end_normal") for p in pipes]),
                 gentle=True)


def cap_axes(tubes, row, sign, pipe, style):
    """The cap past the end ring at ``row`` (outward along ``sign`` times the tangent):
    its rings as axes and centres (see :func:`~cadpipe.geometry.rings.ring_basis`) and
    its pole (None: a flat fan closes the last ring); None for a plain flat cap.

    A round cap's rings lie on the sphere of the end ring's radius; with
    ``envelope=True`` its faces are instead tangent to the sphere of the ball it must
    hold (the end ring's inradius ``rho``): in each meridian the cap is the polygon
    circumscribing that circle with sides tangent at ``0, D, 2D, ...`` and a vertex on
    the axis, ``D = pi / (2m - 1)``, so ring ``j`` sits at angle ``(j - 1/2) D`` and
    distance ``rho / cos(D/2)``. An envelope's flat cap lies ``r`` past the end.
    """
    centre, tangent = tubes.lines.xyz[:, row], sign * tubes.lines.tangents[:, row]
    ring = tubes.axes[row]
    if style == "flat":
        if not pipe.envelope:
            return None
        axes = ring[None].copy()
        axes[0, 2] = centre + _end_radius(pipe, sign) * tangent
        return axes, None
    radius = tubes.ring_radii[row]
    if pipe.envelope:
        m = max(2, pipe.cap_steps)
        step = np.pi / (2 * m - 1)
        lat = (np.arange(1, m) - 0.5) * step
        scale = np.cos(lat) / np.cos(step / 2)
        rise = np.sin(lat) / np.cos(step / 2) * radius * np.cos(np.pi / pipe.sides)
        pole = radius * np.cos(np.pi / pipe.sides) / np.cos(step / 2)
    else:
        m = pipe.cap_steps
        lat = (np.pi / 2) * np.arange(1, m) / m
        scale, rise, pole = np.cos(lat), np.sin(lat) * radius, radius
    axes = np.empty((len(lat), 3, 3))
    axes[:, :2] = scale[:, None, None] * ring[:2]
    axes[:, 2] = centre + rise[:, None] * tangent
    return axes, centre + pole * tangent


def _cap_reach(pipe, style, sign):
    cap = cap_axes(pipe._tubes, 0 if sign < 0 else len(pipe.path) - 1, sign, pipe, style)
    if cap is None:
        return 0.0
    end = pipe.path.points[0 if sign < 0 else -1]
    tip = cap[0][-1, 2] if cap[1] is None else cap[1]
    return float(np.linalg.norm(tip - end))


def _end_radius(pipe, sign):
    return float(pipe.envelope_radii[0 if sign < 0 else -1])


def add_pipe_surfaces(surface, tubes, pipes, *, cap_start, cap_end, parts=None, windows=None,
                      cut=None):
    """Lay out the pipes (``tubes``' groups, in order) in ``surface``: their rings, side
    faces, ball joints and the requested caps (see :meth:`Pipe.surface`).

    ``windows`` (per pipe ``(first, last)``, or None for all of it) lays out only the
    segments ``first..last`` of a pipe (around a closed one they may wrap, ``last <
    first``): the same rings, joints and caps, closed by a flat fan on the ring where the
    window cuts the tube. The clean pieces of a swept solid are built here, as the
    whole pipe is, so no piece can miss a joint or a cap. ``cut`` (per pipe ``(start,
    end)`` bools) closes those of its own ends by a flat fan too, instead of its cap.

    Returns the vertex index of each pipe's first and last ring laid out (its own, not a
    cap's).
    """
    groups, sides = tubes.groups, tubes.sides
    runs, rolls, rows_of, closed, ends = [], [], [], [], []
    for g, pipe in enumerate(pipes):
        first, last = int(groups.first[g]), int(groups.last[g])
        window = None if windows is None else windows[g]
        if window is None:
            rows = np.arange(first, last + 1)
        else:
            count = last - first + 1
            a, b = window
            rows = first + (a + np.arange((b - a) % (count if pipe.closed else count - 1)
                                          + 2)) % count
        axes, roll = _window_axes(tubes, rows, int(tubes.seam_shift[g]), pipe.sides)
        runs.append(axes)
        rolls.append(roll)
        rows_of.append(rows)
        closed.append(pipe.closed and window is None)
        cuts = (False, False) if cut is None else cut[g]
        ends.append((not pipe.closed and rows[0] == first and not cuts[0],
                     not pipe.closed and rows[-1] == last and not cuts[1]))
    # caps: at most the two ends of a chain, or a lone pipe's; a cut end is a flat fan
    capped = [g for g in range(len(pipes)) if (cap_start[g] or cap_end[g]) and not closed[g]]
    caps, rings_before = {}, np.zeros(len(pipes), np.int64)
    for g in capped:
        pipe, (at_start, at_end) = pipes[g], ends[g]
        styles, rows = pipe.cap_styles, rows_of[g]
        start = cap_axes(tubes, rows[0], -1, pipe, styles[0]) \
            if cap_start[g] and at_start else None
        end = cap_axes(tubes, rows[-1], +1, pipe, styles[1]) if cap_end[g] and at_end else None
        if start is not None or end is not None:
            run = runs[g]
            runs[g] = np.concatenate([run[:0] if start is None else start[0][::-1], run,
                                      run[:0] if end is None else end[0]])
            rings_before[g] = 0 if start is None else len(start[0])
        caps[g] = (start, end)
    jointed = {}
    for g, pipe in enumerate(pipes):
        first, rows = int(groups.first[g]), rows_of[g]
        mask = joint_rows_of(tubes, first, int(groups.last[g]), pipe)[rows - first]
        if not closed[g]:                          # a cut or an end is a plain ring
            mask[[0, -1]] = False
        at = np.flatnonzero(mask)
        if at.size:
            jointed[g] = {int(k + rings_before[g]): (int(rows[k]), int(rolls[g][k]))
                          for k in at.tolist()}
    plain = [g for g in range(len(pipes)) if g not in jointed]
    row_start = [None] * len(pipes)
    if plain:
        starts = surface.add_rings([runs[g] for g in plain], sides[plain],
                                   None if parts is None else np.asarray(parts)[plain],
                                   closed=np.asarray(closed)[plain],
                                   seam_shift=tubes.seam_shift[plain])
        for g, start in zip(plain, starts.tolist()):
            row_start[g] = start + int(sides[g]) * np.arange(len(runs[g]))
    for g, rows in jointed.items():
        row_start[g] = _add_jointed_run(surface, tubes, pipes[g], runs[g], rows, closed[g],
                                        int(tubes.seam_shift[g]),
                                        None if parts is None else int(parts[g]))
    for g in capped:
        n, part = int(sides[g]), None if parts is None else int(parts[g])
        for wanted, cap, ring, at_end in (
                (cap_start[g], caps[g][0], int(row_start[g][0]), False),
                (cap_end[g], caps[g][1], int(row_start[g][-1]), True)):
            if not wanted:
                continue
            apex = None if cap is None or cap[1] is None else surface.add_vertices(
                1, lambda out, pole=cap[1]: np.copyto(out[0], pole))
            surface.add_faces(n if apex is not None else n - 2, partial(
                write_fan, ring, n, apex, at_end), part)
    own = [rs[b:b + len(r)] for rs, b, r in zip(row_start, rings_before.tolist(), rows_of)]
    return np.array([o[0] for o in own]), np.array([o[-1] for o in own])


def _window_axes(tubes, rows, shift, sides):
    """(K, 3, 3) ring axes at tube ``rows`` of one pipe and (K,) the vertex roll of each:
    rings past a closed pipe's seam are turned by its seam ``shift`` (their vertex k is
    the ring's vertex k + shift), so they continue the rings before the seam."""
    axes = tubes.axes[rows]
    roll = np.zeros(len(rows), np.int64)
    past = np.flatnonzero(np.diff(rows) < 0)
    if past.size:
        after = slice(int(past[0]) + 1, None)
        alpha = 2 * np.pi * shift / sides
        axes = axes.copy()
        a0, a1 = axes[after, 0].copy(), axes[after, 1].copy()
        axes[after, 0] = np.cos(alpha) * a0 + np.sin(alpha) * a1
        axes[after, 1] = np.cos(alpha) * a1 - np.sin(alpha) * a0
        roll[after] = shift
    return axes, roll

# -- ball joints (corners="round") -------------------------------------------------
def joint_rows_of(tubes, first, last, pipe):
    """(n,) bool: which of ``pipe``'s rings (tube rows ``first..last``) are laid out as
    a ball joint (:func:`_joint`): with ``corners="round"`` and no envelope, the
    corners that :func:`round_corner_rows` names. An envelope's round corners are
    balls that circumscribe the ball of the path's radius, united with the segments
    cut square at the corner (see :meth:`Pipe._swept_plan`): the swept joint's faces
    beside the bend axis fan from one unswept vertex and would cut across that ball."""
    rows = round_corner_rows(tubes, first, last, pipe)
    return rows & (not pipe.envelope)


def round_corner_rows(tubes, first, last, pipe):
    """(n,) bool: with ``corners="round"``, the corners of ``pipe`` (tube rows
    ``first..last``) whose miter tip would stick out farther than the ring polygon's
    own chordal deviation, ``stretch - 1 > 1 - cos(pi / sides)``: they become ball
    joints; gentler corners keep their miter, which already holds the corner's ball."""
    if pipe.corners != "round":
        return np.zeros(last - first + 1, bool)
    return tubes.miter_stretch[first:last + 1] - 1.0 > 1.0 - np.cos(np.pi / pipe.sides)


def _rotate(v, axis, angle):
    """Rodrigues: (..., 3) vectors ``v`` turned by ``angle`` about the unit ``axis``."""
    c, s = np.cos(angle), np.sin(angle)
    return v * c + np.cross(axis, v) * s + np.outer(v @ axis, axis) * (1 - c)


def _joint(tubes, row, pipe):
    """A ball joint at corner ``row``: the rings that sweep the corner's ring about the
    bend axis through the corner point, from the plane across the incoming segment to
    the plane across the outgoing one.

    Only the outside of the bend sweeps (the sphere of the ring radius about the
    corner point, as a ball joint has); the inside keeps the miter ring's vertices,
    where the two segments' cylinders meet.

    Returns ``(outer, rings)``: the (sides,) bool mask of swept vertices and the
    (K, sides, 3) ring vertices (inner vertices repeated; they are one vertex).
    """
    lines = tubes.lines
    n = pipe.sides
    centre = lines.xyz[:, row]
    d_in, d_out = lines.incoming[:, row], lines.directions[:, row]
    turn = float(lines.turning_angles[row])
    axis = np.cross(d_in, d_out)
    axis /= np.linalg.norm(axis)
    miter = ring_basis(n) @ tubes.axes[row]
    outer = (miter - centre) @ lines.bend_directions[:, row] < 0
    radius = tubes.ring_radii[row]
    normal = tubes.normals[:, row]
    binormal = np.cross(lines.tangents[:, row], normal)
    a = 2 * np.pi * np.arange(n) / n
    offsets = radius * (np.cos(a)[:, None] * _rotate(normal[None], axis, -turn / 2)
                        + np.sin(a)[:, None] * _rotate(binormal[None], axis, -turn / 2))
    steps = max(1, int(np.ceil(turn / (np.pi / 2) * pipe.cap_steps)))
    angles = turn * np.arange(steps + 1) / steps
    along = np.outer(offsets @ axis, axis)
    rings = np.empty((len(angles), n, 3))
    for k, angle in enumerate(angles.tolist()):
        rings[k] = centre + along + _rotate(offsets - along, axis, angle)
    rings[:, ~outer] = miter[~outer]
    return outer, rings


def _add_jointed_run(surface, tubes, pipe, run, rows, closed, seam_shift, part):
    """Lay out a run of rings (axes, as :meth:`Surface.add_rings` takes them) whose
    ``rows`` (index in ``run`` -> tube row and vertex roll, see :func:`_window_axes`) get
    ball joints: every ring a row of vertex
    indices (a joint's inner vertices shared by its rings), faces between every two
    rows as for plain rings, those made degenerate by a shared vertex dropped.

    Returns the vertex index of each run row's first ring.
    """
    n, basis = pipe.sides, ring_basis(pipe.sides)
    first = surface.vertex_count
    blocks, table, row_start, count = [], [], np.empty(len(run), np.int64), 0
    for r, axes in enumerate(run):
        if r in rows:
            row, roll = rows[r]
            outer, rings = _joint(tubes, row, pipe)
            outer, rings = np.roll(outer, -roll), np.roll(rings, -roll, axis=1)
            extra = rings[1:, outer].reshape(-1, 3)
            ids = np.empty((len(rings), n), np.int64)
            ids[:] = first + count + np.arange(n)
            ids[1:, outer] = (first + count + n + np.arange(len(extra))).reshape(
                len(rings) - 1, -1)
            blocks += [rings[0], extra]
        else:
            ids = (first + count + np.arange(n))[None]
            blocks.append(basis @ axes)
        row_start[r] = ids[0, 0]
        count += sum(len(b) for b in blocks[-2 if r in rows else -1:])
        table.append(ids)
    vertices = np.concatenate(blocks)
    table = np.concatenate(table)
    upper, lower = table[:-1], table[1:]
    if closed:
        upper = np.vstack([upper, table[-1:]])
        lower = np.vstack([lower, np.roll(table[:1], -seam_shift, axis=1)])
    a, b = upper, np.roll(upper, -1, axis=1)
    c, d = lower, np.roll(lower, -1, axis=1)
    # a swept quad is not flat: split it along the diagonal that folds outwards, so
    # both triangles lie outside the band between its rings (an envelope's joint must
    # not cut into the ball it holds)
    at = [vertices[v - first] for v in (a, b, c, d)]
    fold = np.einsum("...i,...i->...", np.cross(at[1] - at[0], at[2] - at[0]), at[3] - at[0])
    flip = (fold > 0)[..., None]
    faces = np.stack([np.where(flip, np.stack([a, b, d], -1), np.stack([a, b, c], -1)),
                      np.where(flip, np.stack([a, d, c], -1), np.stack([b, d, c], -1))],
                     axis=2).reshape(-1, 3)
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2])
                  & (faces[:, 0] != faces[:, 2])]
    surface.add_vertices(len(vertices), lambda out: np.copyto(out, vertices))
    surface.add_faces(len(faces), lambda out: np.copyto(out, faces), part)
    return row_start
