"""Steps S2-S4: a pipe of regular n-gon rings along a path, closed into a solid.

A :class:`Pipe` is a description (path, radii, sides, caps, frame, ...); its
:meth:`Pipe.mesh` builds the watertight, outward-facing triangle mesh. The
pieces a splice needs (rings, frames) are public, so a transition between two
pipes is built from the same rings the pipes themselves use.
"""

import dataclasses
from dataclasses import KW_ONLY, dataclass
from collections.abc import Mapping
from functools import cached_property, partial
from types import MappingProxyType
from typing import Any

import numpy as np

from cadpipe import limits
from cadpipe._validate import as_choice, as_int, as_positive
from cadpipe.core import float32
from cadpipe.core.distance import segment_distance
from cadpipe.core.vec import cross
from cadpipe.errors import GeometryError, InputError
from cadpipe.geometry.frames import FRAME_MODES, MAX_TWIST_STEP, as_direction
from cadpipe.geometry.loft import Surface
from cadpipe.geometry.bands import band_triangles, clearance
from cadpipe.geometry.cover import piece_covers, segment_covers
from cadpipe.geometry.clearance import (Folds, local_folds,
                                        piece_meets_units, reach)
from cadpipe.geometry.mesh import Mesh
from cadpipe.geometry.path import Path
from cadpipe.geometry.pieces import runs, unit_pieces, unit_points
from cadpipe.geometry.rings import ring_basis
from cadpipe.geometry.surfaces import (add_pipe_surfaces, cap_axes, cap_reach, round_corner_rows,
                                       tubes_of)
from cadpipe.geometry.swept import hull_solid, float32_solid

CAP_STYLES = ("flat", "round")
CORNER_STYLES = ("miter", "round")
MAX_SIDES = 4096


def sides_for_tolerance(radius, tolerance):
    """Fewest sides whose polygon stays within ``tolerance`` of a circle of ``radius``
    (``MAX_SIDES + 1`` where more than :data:`MAX_SIDES` would be needed).

    The half angle a side spans is ``arccos(1 - t/r) = 2 arcsin(sqrt(t / 2r))``; the arcsin
    form keeps its digits for a tolerance far below the radius, where ``1 - t/r`` rounds
    to 1 and the arccos form divides by zero."""
    half = float(tolerance) / (2.0 * float(radius))
    if half >= 1.0:
        return 3
    angle = 2.0 * np.arcsin(np.sqrt(half))
    if angle * (MAX_SIDES + 1) <= np.pi:
        return MAX_SIDES + 1
    return max(3, int(np.ceil(np.pi / angle - 1e-9)))


def _frozen(values):
    out = np.array(values, dtype=np.float64)
    out.flags.writeable = False
    return out


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
    miter_limit: float = 4.0
    cap_segments: int | None = None
    strict: bool = False

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
                raise InputError(f"tolerance {self.tolerance:g} needs more than {MAX_SIDES} "
                                 "sides; use a larger tolerance", key="tolerance")
        set_("sides", as_int(sides, "sides", low=3, high=MAX_SIDES))
        if self.cap_segments is not None:
            set_("cap_segments", as_int(self.cap_segments, "cap_segments", low=1,
                                        high=MAX_SIDES))
        radii = np.broadcast_to(radius, (len(source),))
        if float(radii.min()) <= source._tolerance:
            raise InputError(f"{radii.min():g} is too small for this path, whose points "
                             f"closer than {source._tolerance:g} count as one; use a larger "
                             "radius", key="radius")
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
        return tuple(cap_reach(self, style, sign)
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
        return MappingProxyType({
            "kind": "pipe", "sides": self.sides, "radius_min": float(self.radii.min()),
            "radius_max": float(self.radii.max()), "path_length": self.path.length,
            "path_points": len(self.path), "closed": self.closed,
            "caps": "/".join(dict.fromkeys(self.cap_styles)),
            "envelope": self.envelope, "frame": self.frame, "corners": self.corners})

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
                                   lines.segments[:, cols], axis=0)
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
        step = float32.step(largest, float32.FINEST)
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
        return unit_points(self, np.arange(len(self.path.segments)), rows, overlap=overlap)

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
        units = [segment_covers(self, np.flatnonzero(~merged))]
        if merged.any():
            units.append(piece_covers(unit_pieces(self, np.flatnonzero(merged), joints,
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
        :meth:`_swept_solid` and :func:`float32_solid`); where it folds,
        ``attributes["merged"]`` names the merged stretches."""
        solid, stretches = self._swept_solid(folds)
        if not folds:
            return float32_solid(solid, attributes=self.attributes)
        arc = self.path.arc_length
        spans = [(float(arc[a]), float(arc[(b + 1) % len(arc)] if b + 1 < len(arc)
                                     else self.path.length)) for a, b in stretches]
        names = "; ".join(f"path points {a}..{(b + 1) % len(arc)} (arc length {s:.6g} to "
                          f"{e:.6g})" for (a, b), (s, e) in zip(stretches, spans))
        return float32_solid(solid, attributes={
            **self.attributes, "merged": names,
            "merged_arc_lengths": tuple(x for span in spans for x in span),
            "folds": folds.messages[0]})

    def _swept_solid(self, folds, ends=(True, True)):
        """The tube with each stretch that folds replaced by the union of its convex
        units (:func:`unit_points`), the clean stretches kept as they are, all united by
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
        pieces = unit_points(self, np.flatnonzero(merged), joints, tongue=TONGUE, capped=ends)
        solids = [hull_solid(p - middle) for p in pieces]
        if not merged.all():
            for a, b in runs(~merged, self.closed):
                piece = self._piece(a, b, ends)
                solids.append(Mesh.trusted(piece.vertices - middle, piece.faces)
                              .to_manifold("pipe"))
        solid = manifold3d.Manifold.batch_boolean(solids, manifold3d.OpType.Add)
        return solid.translate(tuple(middle.tolist())), runs(merged, self.closed)

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
#: merged units reach this fraction of the ring radius into their neighbours (see unit_points)
TONGUE = 1e-3


