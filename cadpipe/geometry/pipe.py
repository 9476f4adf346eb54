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
from typing import Any

import numpy as np

from cadpipe import _deprecated
from cadpipe._validate import as_choice, as_int, as_positive
from cadpipe._vec import cross
from cadpipe.errors import GeometryError, InputError
from cadpipe.geometry.frames import FRAME_MODES, as_direction
from cadpipe.geometry.loft import Surface, write_fan
from cadpipe.geometry.mesh import Mesh
from cadpipe.geometry.path import Path, polylines
from cadpipe.geometry.rings import Tubes, ring_basis

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
    caps : {"flat", "round"}
        End caps of an open path; a closed path needs none.
    envelope : bool
        False: ring vertices on the circle (the polygon lies inside the round tube).
        True: a conservative safety envelope: the solid contains every ball of radius
        ``r(s)`` centred on the path (``r`` interpolated linearly between points),
        through tapers, corners and caps (a flat cap then lies ``r`` beyond the end).
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
        tip sticks out.
    bend_radius : float, optional
        Deprecated: rounds the path itself with arcs of this radius (the pipe then
        follows :meth:`Path.fillet`'s path); pass ``path.fillet(bend_radius)[0]``.
    miter_limit : float
        Largest allowed stretch ``1/cos(turn/2)`` of a mitered ring (default 4, as SVG).
    cap_segments : int, optional
        Latitude steps of a round cap or ball joint (default ``max(2, sides // 4)``).
    repair : bool
        If the tube would intersect itself, build the solid as a manifold3d union of
        its convex units instead of raising :class:`GeometryError`.
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
    repair: bool = False

    def __post_init__(self):
        set_ = partial(object.__setattr__, self)
        source = self.path if isinstance(self.path, Path) else Path(self.path)
        radius = as_positive(self.radius, "radius", count=len(source))
        set_("caps", as_choice(self.caps, "caps", CAP_STYLES))
        set_("frame", as_choice(self.frame, "frame", FRAME_MODES))
        set_("corners", as_choice(self.corners, "corners", CORNER_STYLES))
        set_("envelope", bool(self.envelope))
        set_("repair", bool(self.repair))
        for name in ("normal", "end_normal"):
            value = getattr(self, name)
            set_(name, None if value is None else tuple(as_direction(value, name).tolist()))
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
        set_("_given_path", source)
        if self.corners == "round":
            bend = 2.0 * float(radii.max()) if self.bend_radius is None else self.bend_radius
            set_("bend_radius", float(as_positive(bend, "bend_radius")))
            radii = radii[source.fillet_sources(self.bend_radius)]
            source = source.filleted(self.bend_radius)
        else:
            set_("bend_radius", None)
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
        if self.corners == "round" and "path" not in changes:
            changes["path"] = self._given_path
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

    @property
    def ring_radii(self) -> np.ndarray:
        """(N,) distance of ring vertices from the axis (radius, or circumradius)."""
        return self.radii * envelope_factor(self.sides) if self.envelope else self.radii

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
            "path_points": len(self.path), "closed": self.closed, "caps": self.caps,
            "envelope": self.envelope, "frame": self.frame, "corners": self.corners},
            "Pipe.attributes")

    # -- checks and mesh -----------------------------------------------------
    def self_intersections(self) -> list[str]:
        """Deprecated: :meth:`self_intersection_findings`."""
        _deprecated.warn("Pipe.self_intersections()", "Pipe.self_intersection_findings()")
        return self.self_intersection_findings()

    def self_intersection_findings(self) -> list[str]:
        """Where the tube would cut through itself: a list of human-readable findings.

        Returns
        -------
        findings : list of str
            Empty for a tube that does not cut through itself.


        Checks miter limits, rings that overlap within a segment (the radius exceeds
        the local bend radius) and non-neighbouring parts of the tube closer than
        the sum of their radii.
        """
        return self._tubes.self_intersection_findings()[0]

    def mesh(self) -> Mesh:
        """The closed, outward-oriented, watertight triangle mesh of this pipe.

        Returns
        -------
        mesh : Mesh

        Raises :class:`GeometryError` if the tube intersects itself, unless the pipe
        was made with ``repair=True``.
        """
        problems = self.self_intersection_findings()
        if problems:
            if not self.repair:
                raise GeometryError(f"the pipe intersects itself: {problems[0]}"
                                    + (f" (and {len(problems) - 1} more)" if len(problems) > 1
                                       else "")
                                    + "; smooth the path or reduce the radius, or repair it",
                                    fix={"repair": True})
            return self._repaired_mesh()
        vertices, faces = self.surface(cap_start=not self.closed, cap_end=not self.closed)
        return Mesh.trusted(vertices, faces, attributes=self.attributes)

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
        surface = Surface()
        add_pipe_surfaces(surface, self._tubes, [self], cap_start=[cap_start], cap_end=[cap_end])
        vertices, faces, _ = surface.build()
        return vertices, faces

    def units(self, overlap: float = 0.0) -> list[np.ndarray]:
        """Deprecated: :meth:`convex_pieces` (``units`` is a length unit elsewhere)."""
        _deprecated.warn("Pipe.units()", "Pipe.convex_pieces()")
        return self.convex_pieces(overlap)

    def convex_pieces(self, overlap: float = 0.0) -> list[np.ndarray]:
        """Convex pieces whose union is the tube: each path unit, plus round caps.

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
        unit); a round cap is its end ring, cap rings and pole. ``overlap`` pushes
        each unit's rings that far outward along its segment, so that neighbouring
        units overlap instead of merely touching (booleans treat touching solids as
        apart).
        """
        rings = self.rings()
        cur = np.arange(len(self.path.segments))
        nxt = (cur + 1) % len(rings)
        shift = overlap * self.path.directions[:, None, :]
        pieces = list(np.concatenate([rings[cur] - shift, rings[nxt] + shift], axis=1))
        if not self.closed and self.caps == "round":
            for row, sign in ((0, -1), (len(rings) - 1, 1)):
                axes, pole = cap_axes(self._tubes, row, sign, self)
                cap = np.matmul(ring_basis(self.sides), axes).reshape(-1, 3)
                pieces.append(np.concatenate([rings[row], cap, pole[None]]))
        return pieces

    def _repaired_mesh(self):
        """Union of the convex units through manifold3d: valid even where the tube folds."""
        import manifold3d

        overlap = 1e-6 * float(self.ring_radii.max())
        hulls = [manifold3d.Manifold.hull_points(p) for p in self.convex_pieces(overlap)]
        solid = manifold3d.Manifold.batch_boolean(hulls, manifold3d.OpType.Add)
        return Mesh.from_manifold(solid, attributes={**self.attributes, "repaired": True})


def tubes_of(pipes):
    """The pipes' rings, frames and checks as one :class:`~cadpipe.geometry.rings.Tubes` batch."""
    return Tubes(polylines([p.path for p in pipes]),
                 np.concatenate([p.ring_radii for p in pipes]),
                 [p.sides for p in pipes], [p.miter_limit for p in pipes],
                 patent=[p.frame == "patent" for p in pipes],
                 normals=np.array([as_direction(p.normal, "normal") for p in pipes]),
                 end_normals=np.array([as_direction(p.end_normal, "end_normal") for p in pipes]),
                 gentle=True)


def cap_axes(tubes, row, sign, pipe):
    """A round cap's latitude rings past the end ring at ``row`` (outward from the
    tube, along ``sign`` times the tangent) as ring axes and centres (see
    :func:`~cadpipe.geometry.rings.ring_basis`), and its pole."""
    m = pipe.cap_steps
    lat = (np.pi / 2) * np.arange(1, m) / m
    scale = 1.0 / np.cos(np.pi / (4 * m)) if pipe.envelope else 1.0
    centre = tubes.lines.xyz[:, row]
    rise = tubes.ring_radii[row] * scale * sign * tubes.lines.tangents[:, row]
    axes = np.empty((m - 1, 3, 3))
    axes[:, :2] = (scale * np.cos(lat))[:, None, None] * tubes.axes[row, :2]
    axes[:, 2] = centre + np.sin(lat)[:, None] * rise
    return axes, centre + rise


def add_pipe_surfaces(surface, tubes, pipes, *, cap_start, cap_end, parts=None):
    """Lay out the pipes (``tubes``' groups, in order) in ``surface``: their rings, side
    faces and the requested caps (see :meth:`Pipe.surface`).

    Returns the vertex index of each pipe's first and last ring (its own, not a cap's).
    """
    groups, sides = tubes.groups, tubes.sides
    firsts, lasts = groups.first.tolist(), groups.last.tolist()
    runs = [tubes.axes[a:b + 1] for a, b in zip(firsts, lasts)]
    # caps: at most the two ends of a chain, or a lone pipe's
    capped = [g for g, pipe in enumerate(pipes)
              if (cap_start[g] or cap_end[g]) and not pipe.closed]
    caps, rings_before = {}, np.zeros(len(pipes), np.int64)
    for g in capped:
        pipe = pipes[g]
        round_caps = pipe.caps == "round"
        start = cap_axes(tubes, firsts[g], -1, pipe) if cap_start[g] and round_caps else None
        end = cap_axes(tubes, lasts[g], +1, pipe) if cap_end[g] and round_caps else None
        if start is not None or end is not None:
            run = runs[g]
            runs[g] = np.concatenate([run[:0] if start is None else start[0][::-1], run,
                                      run[:0] if end is None else end[0]])
            rings_before[g] = 0 if start is None else len(start[0])
        caps[g] = (start, end)
    first = surface.add_rings(runs, sides, parts, closed=groups.closed,
                              seam_shift=tubes.seam_shift)
    for g in capped:
        n, part = int(sides[g]), None if parts is None else int(parts[g])
        for wanted, cap, ring, at_end in (
                (cap_start[g], caps[g][0], int(first[g]), False),
                (cap_end[g], caps[g][1], int(first[g]) + (len(runs[g]) - 1) * n, True)):
            if not wanted:
                continue
            apex = None if cap is None else surface.add_vertices(
                1, lambda out, pole=cap[1]: np.copyto(out[0], pole))
            surface.add_faces(n if cap is not None else n - 2, partial(
                write_fan, ring, n, apex, at_end), part)
    ring0 = first + rings_before * sides
    return ring0, ring0 + (groups.counts - 1) * sides
