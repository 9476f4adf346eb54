"""Separation certificates: the source's steps 3 and 4, made checkable.

Where two objects' boxes overlap, the source looks inside the overlap region
for a polyline that splits it with each object on its own side -- a proof
that they do not touch. In 3D that proof lives in a plane: the intersection of
two solids lies inside the overlap box ``O`` of their AABBs, and if the parts
of the solids inside ``O``, projected onto a plane, are disjoint, the solids
are. The steps:

1. ``O`` and the plane of its two largest extents (the other axis planes are
   tried next if that one fails). Each object's part inside ``O`` is projected
   onto it: meshes through manifold3d (clip, then project), ball chains as
   the hulls of their units' discs (circumscribed polygons, so never smaller).
   ``R`` is the projected overlap box.
2. The two points where the projected boxes' boundaries cross are ``p_start``
   and ``p_end``; they split ``R``'s boundary into an arc where object A
   reaches in from outside and one where B does.
3. Segment solution: the straight cut ``p_start -> p_end`` if it touches
   neither object.
4. Otherwise the rotating-ray chain. From ``p_start`` a trial ray runs along
   the reference edge ``e_r`` of ``R``; the first object it hits is ``O_s``.
   The ray rotates about the current point (steps of ``theta``, at most 180
   degrees, refined by bisection) until it first misses ``O_s``: that ray
   grazes ``O_s``, and the chain goes to the grazing point. If the ray runs
   into the other object ``O_e`` there, the roles swap -- ``O_s`` and ``O_e``
   exchange, the blocked ray is the new reference and the rotation reverses --
   otherwise the chain keeps wrapping around ``O_s`` with the same reference.
   The chain ends when ``p_end`` is in sight; it fails (no certificate) when
   no ray clears ``O_s`` or a new segment touches the chain.

Whatever the search returns is checked by :func:`verify`, which shares no
code with it (its predicates are shapely's): the chain must stay in ``R``, be
simple, touch neither projected object, and cut ``R`` into pieces none of
which holds both objects.
The regions are dilated by a small margin first (a hair beyond manifold3d's
2D rounding), so a verified certificate is a proof of zero intersection.
"""

from dataclasses import dataclass
from pathlib import Path as FilePath

import numpy as np

#: angular step of the rotating ray, degrees (the source's theta)
STEP_DEGREES = 2.0
#: bisection steps refining the first ray that clears O_s
REFINE_STEPS = 30
#: sides of the circumscribed polygon standing in for a ball's projected disc
CIRCLE_SIDES = 32
#: margin added around projected regions, relative to the coordinates' size ...
MARGIN = 1e-6
#: ... and never below manifold3d's 2D grid (Clipper2 keeps 8 decimals)
FLOOR = 1e-7
#: largest number of chain segments before the search gives up
MAX_SEGMENTS = 400


def _cross2(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


@dataclass(frozen=True, eq=False)
class Certificate:
    """A proof that two objects do not touch, in one axis plane.

    Attributes
    ----------
    names : (str, str)
    kind : {"boxes", "empty", "segment", "chain"}
        ``"boxes"``: the AABBs are disjoint along ``axes[0]``; ``"empty"``: one
        object has no part inside the overlap box (a box-shaped object fills its
        own box, so no chain could avoid it); ``"segment"``: the source's
        straight cut; ``"chain"``: its rotating-ray polyline.
    axes : (int, int)
        World axes spanning the plane (0 = x, 1 = y, 2 = z).
    rectangle : (2, 2) array
        ``R``: lower and upper corner in the plane.
    boxes : (2, 2, 2) array
        Each object's AABB projected to the plane (lower, upper corner).
    chain : (K, 2) array
        The separating polyline from ``p_start`` to ``p_end`` (empty for "boxes").
    regions : (list, list)
        Each object's projected part inside ``O`` as polygon rings (margin included).
    """

    names: tuple
    kind: str
    axes: tuple
    rectangle: np.ndarray
    boxes: np.ndarray
    chain: np.ndarray
    regions: tuple

    def verify(self):
        """True if the certificate proves separation; see :func:`verify`."""
        return verify(self)[0]

    def to_svg(self, size=480):
        """An SVG drawing of R, both projected objects and the chain."""
        from cadpipe.collision.certificate_svg import render

        return render(self, size)

    def save_svg(self, path):
        """Write :meth:`to_svg` to ``path`` (whole or not at all)."""
        from cadpipe.io.files import atomic_path

        with atomic_path(path) as tmp:
            FilePath(tmp).write_text(self.to_svg(), encoding="utf-8")
        return FilePath(path)


# -- projections ------------------------------------------------------------------
def _plane_matrix(normal):
    """Proper rotation taking world coordinates to (u, v, normal), cyclic order."""
    order = [(normal + 1) % 3, (normal + 2) % 3, normal]
    return np.eye(3)[order]


def _project(body, pose, lo, hi, normal):
    """manifold3d CrossSection of the body's part inside box [lo, hi], in (u, v)."""
    import manifold3d

    rot = _plane_matrix(normal)
    blo, bhi = rot @ lo, rot @ hi
    if body.kind == "mesh":
        place = np.hstack([rot @ pose[:3, :3], (rot @ pose[:3, 3])[:, None]])
        solid = body.solid.transform(place)
        box = manifold3d.Manifold.cube(tuple(bhi - blo)).translate(tuple(blo))
        shadow = (solid ^ box).project()
        return manifold3d.CrossSection(shadow.to_polygons(), manifold3d.FillRule.Positive)
    chain = body.chain.moved(pose)
    ub = chain.unit_bounds
    near = np.flatnonzero(np.all((ub[:, 0] <= hi) & (ub[:, 1] >= lo), axis=1))
    angles = 2 * np.pi * np.arange(CIRCLE_SIDES) / CIRCLE_SIDES
    ring = np.stack([np.cos(angles), np.sin(angles)], axis=1) / np.cos(np.pi / CIRCLE_SIDES)
    hulls = []
    for unit in near:
        ends = np.stack([chain.starts[unit], chain.ends[unit]]) @ rot.T
        radii = (chain.start_radii[unit], chain.end_radii[unit])
        pts = np.concatenate([e[:2] + r * ring for e, r in zip(ends, radii)])
        hulls.append(manifold3d.CrossSection.hull_points(pts))
    if not hulls:
        return manifold3d.CrossSection()
    return manifold3d.CrossSection.batch_boolean(hulls, manifold3d.OpType.Add)


def _rings(section):
    return [np.asarray(p, np.float64) for p in section.to_polygons() if len(p) >= 3]


def _edges(rings):
    if not rings:
        return np.empty((0, 2, 2))
    return np.concatenate([np.stack([r, np.roll(r, -1, axis=0)], axis=1) for r in rings])


# -- the search ---------------------------------------------------------------------
class _Obstacle:
    """A projected object for ray casting: its edges and rings (even-odd inside)."""

    def __init__(self, rings):
        self.rings = rings
        self.edges = _edges(rings)

    def _hits(self, origin, directions):
        """(K, E) distance along each ray to each edge it meets (inf: none)."""
        q0 = self.edges[:, 0]
        s = self.edges[:, 1] - q0
        w = q0 - origin
        den = _cross2(directions[:, None], s[None])
        safe = np.where(den != 0, den, 1.0)
        t = _cross2(w[None], s[None]) / safe
        u = _cross2(w[None], directions[:, None]) / safe
        return np.where((den != 0) & (t >= 0) & (u >= 0) & (u <= 1), t, np.inf)

    def first_hit(self, origin, directions):
        """Distance along each ray to the first edge it meets (inf: none)."""
        if len(self.edges) == 0:
            return np.full(len(directions), np.inf)
        return self._hits(origin, directions).min(axis=1)

    def last_hit(self, origin, direction, limit):
        """Distance along one ray to the last edge it meets before ``limit``."""
        t = self._hits(origin, direction[None])[0]
        t = t[t <= limit]
        return float(t.max()) if t.size else np.inf

    def contains(self, point):
        return _inside_rings(self.rings, point)


def _inside_rings(rings, point):
    """Even-odd point in polygon over all rings (holes included)."""
    count = 0
    for r in rings:
        a, b = r, np.roll(r, -1, axis=0)
        crosses = (a[:, 1] > point[1]) != (b[:, 1] > point[1])
        x = a[:, 0] + (point[1] - a[:, 1]) * (b[:, 0] - a[:, 0]) / np.where(
            b[:, 1] != a[:, 1], b[:, 1] - a[:, 1], 1.0)
        count += int(np.count_nonzero(crosses & (x > point[0])))
    return count % 2 == 1


def _exit_length(origin, directions, lo, hi):
    """How far each ray from ``origin`` (inside R) runs before leaving R."""
    with np.errstate(divide="ignore", invalid="ignore"):
        to_hi = np.where(directions > 0, (hi - origin) / directions, np.inf)
        to_lo = np.where(directions < 0, (lo - origin) / directions, np.inf)
    return np.maximum(np.minimum(to_hi, to_lo).min(axis=1), 0.0)


def _box_crossings(box_a, box_b):
    """Points where the boundaries of two axis-aligned rectangles cross."""
    def edges(box):
        (x0, y0), (x1, y1) = box
        horizontal = [((x0, x1), y0), ((x0, x1), y1)]
        vertical = [((y0, y1), x0), ((y0, y1), x1)]
        return horizontal, vertical

    found = []
    ha, va = edges(box_a)
    hb, vb = edges(box_b)
    for horizontal, vertical in ((ha, vb), (hb, va)):
        for (x0, x1), y in horizontal:
            for (y0, y1), x in vertical:
                if x0 < x < x1 and y0 < y < y1:
                    found.append((x, y))
    return np.array(found, np.float64).reshape(-1, 2)


class _Boundary:
    """R's boundary, by arc length counter-clockwise from the lower-left corner."""

    def __init__(self, lo, hi):
        self.lo, self.hi = lo, hi
        w, h = hi - lo
        self.length = 2.0 * (w + h)
        self.corners = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
        self.corner_at = np.array([0.0, w, w + h, 2 * w + h])

    def position(self, points):
        """Arc length of points on the boundary (each snapped to its nearest side)."""
        p = np.atleast_2d(points)
        (x0, y0), (x1, y1) = self.lo, self.hi
        w, h = x1 - x0, y1 - y0
        side = np.argmin(np.abs([p[:, 1] - y0, p[:, 0] - x1, p[:, 1] - y1, p[:, 0] - x0]), axis=0)
        along = np.choose(side, [p[:, 0] - x0, w + p[:, 1] - y0, w + h + x1 - p[:, 0],
                                 2 * w + h + y1 - p[:, 1]])
        return np.mod(along, self.length)

    def distance(self, points):
        """Distance of points (inside R) to the boundary."""
        p = np.atleast_2d(points)
        return np.minimum(np.min(p - self.lo, axis=1), np.min(self.hi - p, axis=1))

    def point(self, s):
        s = float(np.mod(s, self.length))
        k = int(np.searchsorted(self.corner_at, s, side="right")) - 1
        a, b = self.corners[k], self.corners[(k + 1) % 4]
        return a + (s - self.corner_at[k]) * (b - a) / np.linalg.norm(b - a)


def _touches(boundary, rings, tol):
    """Arc-length intervals of R's boundary that a region's rings lie on."""
    found = []
    for r in rings:
        on = boundary.distance(r) <= tol
        along = on & np.roll(on, -1) & (boundary.distance(0.5 * (r + np.roll(r, -1, axis=0)))
                                        <= tol)
        s = boundary.position(r)
        for i in np.flatnonzero(on):
            j = (i + 1) % len(r)
            if along[i] and abs(s[j] - s[i]) < 0.5 * boundary.length:
                found.append((min(s[i], s[j]), max(s[i], s[j])))
            else:
                found.append((s[i], s[i]))
    return found


def _endpoints(boundary, regions, crossings, tol):
    """Where the chain may start and end.

    The source takes the two box crossings. A chain can only end where neither
    object touches R's boundary, so the touched stretches must form one run per
    object around the boundary; each crossing is kept if it lies in a gap
    between the runs, else the gap's midpoint is used. Returns
    ``(p_start, p_end)``, or None if no single chain can split the touches.
    """
    marks = sorted((lo, hi, label) for label, rings in enumerate(regions)
                   for lo, hi in _touches(boundary, rings, tol))
    labels = [m[2] for m in marks]
    changes = sum(labels[k] != labels[k - 1] for k in range(len(labels)))
    crossing_at = boundary.position(crossings)
    if changes == 0:
        if not marks:                         # nothing touches: the crossings will do
            return crossings[0], crossings[1]
        # one object touches: leave its run through the widest free stretch
        starts = np.array([m[0] for m in marks])
        reach = np.maximum.accumulate([m[1] for m in marks])
        gaps = np.append(starts[1:], starts[0] + boundary.length) - reach
        k = int(np.argmax(gaps))
        g0, width = reach[k], gaps[k]
        return boundary.point(g0 + 0.25 * width), boundary.point(g0 + 0.75 * width)
    if changes != 2:
        return None
    first_b = next(k for k in range(len(marks)) if labels[k] == 1 and labels[k - 1] == 0)
    first_a = next(k for k in range(len(marks)) if labels[k] == 0 and labels[k - 1] == 1)
    ends = []
    for k in (first_b, first_a):             # gap before B's run, then before A's run
        g0 = marks[k - 1][1]
        g1 = marks[k][0] + (boundary.length if marks[k][0] < g0 else 0.0)
        inside = [c for c in crossing_at if g0 < c < g1 or g0 < c + boundary.length < g1]
        ends.append(boundary.point(inside[0] if inside else 0.5 * (g0 + g1)))
    return ends[0], ends[1]


def _rotate(vector, angles):
    c, s = np.cos(angles), np.sin(angles)
    return np.stack([c * vector[0] - s * vector[1], s * vector[0] + c * vector[1]], axis=1)


def _segments_cross(p, q, segments):
    """Whether segment p-q properly meets any of ``segments`` (K, 2, 2)."""
    if len(segments) == 0:
        return False
    a, b = segments[:, 0], segments[:, 1]
    d1 = _cross2(q - p, a - p)
    d2 = _cross2(q - p, b - p)
    d3 = _cross2(b - a, p - a)
    d4 = _cross2(b - a, q - a)
    return bool(np.any((d1 * d2 <= 0) & (d3 * d4 <= 0)))


class _Search:
    """The rotating-ray chain of step 4 inside R (see the module docstring)."""

    def __init__(self, lo, hi, obstacles, step):
        self.lo, self.hi = lo, hi
        self.obstacles = obstacles
        self.angles = np.radians(np.arange(0.0, 180.0 + 1e-9, step))
        self.tiny = 1e-9 * float(np.max(hi - lo))

    def clear(self, p, q):
        """Segment p-q touches neither obstacle."""
        d = (q - p)[None]
        length = np.linalg.norm(d)
        if length == 0:
            return True
        for ob in self.obstacles:
            if ob.first_hit(p, d / length)[0] <= length or ob.contains(0.5 * (p + q)):
                return False
        return True

    def misses(self, p, direction, ob):
        length = _exit_length(p, direction[None], self.lo, self.hi)[0]
        return length > self.tiny and ob.first_hit(p, direction[None])[0] > length

    def run(self, p_start, p_end, reference, sense, first):
        chain = [p_start]
        p, ref, s_index, swapped = p_start, reference, first, False

        def sense_of(index):          # wrapping A and wrapping B turn opposite ways
            return sense if index == first else -sense

        for _ in range(MAX_SEGMENTS):
            if self.clear(p, p_end):
                return np.array(chain + [p_end])
            if self.misses(p, ref, self.obstacles[s_index]):
                # O_s is passed: aim at p_end and wrap whichever object blocks it
                ref = (p_end - p) / np.linalg.norm(p_end - p)
                hits = [ob.first_hit(p, ref[None])[0] for ob in self.obstacles]
                s_index = int(np.argmin(hits))
            o_s, o_e = self.obstacles[s_index], self.obstacles[1 - s_index]
            turn = sense_of(s_index)
            dirs = _rotate(ref, turn * self.angles)
            length = _exit_length(p, dirs, self.lo, self.hi)
            hits = o_s.first_hit(p, dirs)
            free = (length > self.tiny) & (hits > length)
            if not free[1:].any():
                return None                       # no ray clears O_s: cannot separate here
            k = 1 + int(np.argmax(free[1:]))
            # bisect between the last ray hitting O_s and the first clearing it; the
            # grazing point is where the last hitting ray leaves O_s for good
            lo_a, hi_a = self.angles[k - 1], self.angles[k]
            for _ in range(REFINE_STEPS):
                mid = 0.5 * (lo_a + hi_a)
                d = _rotate(ref, np.array([turn * mid]))[0]
                if self.misses(p, d, o_s):
                    hi_a = mid
                else:
                    lo_a = mid
            d = _rotate(ref, np.array([turn * lo_a]))[0]
            hit_point = p + o_s.last_hit(p, d, _exit_length(p, d[None], self.lo, self.hi)[0]) * d
            d = _rotate(ref, np.array([turn * hi_a]))[0]
            blocked = o_e.first_hit(p, d[None])[0]
            graze = float(np.dot(hit_point - p, d))
            if graze <= self.tiny:
                return None
            if blocked <= graze:                  # O_e in the way before O_s is passed:
                if swapped:                       # wrap O_e instead (swap, reverse) --
                    return None                   # unless that was just tried here
                ref, s_index, swapped = d, 1 - s_index, True
                continue
            q = p + graze * d
            built = np.stack([chain[:-2], chain[1:-1]], axis=1) if len(chain) > 2 else \
                np.empty((0, 2, 2))
            if _segments_cross(p, q, built):
                return None                       # the ray touches the chain built so far
            chain.append(q)
            p, swapped = q, False
        return None


def _start(lo, hi, p_start, obstacles, search):
    """Reference edge at p_start (the R edge whose trial ray hits an object first),
    the rotation sense turning it into R, and which object it hits first."""
    centre = 0.5 * (lo + hi)
    best = None
    for d in np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]):
        reach = _exit_length(p_start, d[None], lo, hi)[0]
        probe = p_start + 0.5 * reach * d
        if reach <= search.tiny or not (np.isclose(probe, lo) | np.isclose(probe, hi)).any():
            continue                      # not along an edge of R
        hits = [ob.first_hit(p_start, d[None])[0] for ob in obstacles]
        k = int(np.argmin(hits))
        if best is None or hits[k] < best[0]:
            best = (hits[k], d, 1.0 if _cross2(d, centre - p_start) > 0 else -1.0, k)
    return best


def find_certificate(body_a, pose_a, body_b, pose_b, names=("a", "b"),
                     step_degrees=STEP_DEGREES):
    """A verified :class:`Certificate` that the two placed bodies do not touch, or None."""
    lo_a, hi_a = _world_box(body_a, pose_a)
    lo_b, hi_b = _world_box(body_b, pose_b)
    lo, hi = np.maximum(lo_a, lo_b), np.minimum(hi_a, hi_b)
    if np.any(lo > hi):
        axis = int(np.argmax(lo - hi))
        plane = (axis, (axis + 1) % 3)
        boxes = np.array([[lo_a[list(plane)], hi_a[list(plane)]],
                          [lo_b[list(plane)], hi_b[list(plane)]]])
        cert = Certificate(tuple(names), "boxes", plane, boxes[0], boxes, np.empty((0, 2)),
                           ([], []))
        return cert if cert.verify() else None
    for normal in np.argsort(hi - lo, kind="stable"):
        cert = _certificate_in_plane(body_a, pose_a, body_b, pose_b, names, lo, hi,
                                     (lo_a, hi_a, lo_b, hi_b), int(normal), step_degrees)
        if cert is not None:
            return cert
    return None


def _world_box(body, pose):
    points, pad = body.hull
    world = points @ pose[:3, :3].T + pose[:3, 3]
    return (world - pad[:, None]).min(axis=0), (world + pad[:, None]).max(axis=0)


def _certificate_in_plane(body_a, pose_a, body_b, pose_b, names, lo, hi, boxes, normal,
                          step_degrees):
    import manifold3d

    plane = ((normal + 1) % 3, (normal + 2) % 3)
    idx = list(plane)
    lo2, hi2 = lo[idx], hi[idx]
    box_a = np.array([boxes[0][idx], boxes[1][idx]])
    box_b = np.array([boxes[2][idx], boxes[3][idx]])
    crossings = _box_crossings(box_a, box_b)
    if len(crossings) != 2:
        return None                            # not the source's two-crossing overlap
    margin = max(MARGIN * float(np.max(np.abs([lo, hi]))), MARGIN * float(np.max(hi2 - lo2)),
                 FLOOR)
    rect = manifold3d.CrossSection.square(tuple(hi2 - lo2)).translate(tuple(lo2))
    sections = [(_project(body, pose, lo, hi, normal) ^ rect).offset(
        margin, manifold3d.JoinType.Miter) ^ rect
        for body, pose in ((body_a, pose_a), (body_b, pose_b))]
    if (sections[0] ^ sections[1]).area() > 0:
        return None                            # the shadows overlap in this plane
    regions = tuple(_rings(s) for s in sections)
    rectangle = np.array([lo2, hi2])
    boxes2 = np.array([box_a, box_b])
    if not regions[0] or not regions[1]:       # one object has nothing inside the overlap box
        cert = Certificate(tuple(names), "empty", plane, rectangle, boxes2, np.empty((0, 2)),
                           regions)
        return cert if cert.verify() else None
    boundary = _Boundary(lo2, hi2)
    ends = _endpoints(boundary, regions, crossings, 2 * margin)
    if ends is None:
        return None                            # the objects touch R's boundary in turns
    obstacles = [_Obstacle(_rings(s.offset(10 * margin, manifold3d.JoinType.Miter)))
                 for s in sections]
    search = _Search(lo2, hi2, obstacles, step_degrees)
    for p_start, p_end in (ends, ends[::-1]):
        if search.clear(p_start, p_end):
            kind, chain = "segment", np.array([p_start, p_end])
        else:
            start = _start(lo2, hi2, p_start, obstacles, search)
            if start is None:
                continue
            kind = "chain"
            chain = search.run(p_start, p_end, start[1], start[2], start[3])
            if chain is None:
                continue
        cert = Certificate(tuple(names), kind, plane, rectangle, boxes2, chain, regions)
        if cert.verify():
            return cert
    return None


# -- the verifier ---------------------------------------------------------------------
# Shapely's predicates (GEOS), none of the search's own geometry: a bug in one cannot
# fool the other.
def verify(cert):
    """``(ok, reason)``: does ``cert`` prove that its two objects are apart?

    Independent of the search: every predicate here is shapely's. For "boxes":
    the two boxes are disjoint along the plane's first axis. Otherwise: the chain
    runs inside R from boundary to boundary, is simple, and touches neither
    region (even-odd polygons of the rings, margin included); R cut along the
    chain falls into pieces, and no piece holds area of both regions, so every
    path from one object to the other crosses the chain.
    """
    import shapely
    from shapely.ops import split

    if cert.kind == "boxes":
        (a_lo, a_hi), (b_lo, b_hi) = cert.boxes
        apart = a_hi[0] < b_lo[0] or b_hi[0] < a_lo[0]
        return apart, "boxes apart" if apart else "boxes overlap on the first axis"
    if cert.kind == "empty":
        empty = not cert.regions[0] or not cert.regions[1]
        return empty, "an object has no part in the overlap box" if empty else \
            "both objects reach into the overlap box"
    lo, hi = (np.asarray(c, np.float64) for c in cert.rectangle)
    chain = np.asarray(cert.chain, np.float64)
    size = float(np.max(hi - lo))
    tol = 1e-9 * size
    if len(chain) < 2 or np.any(chain < lo - tol) or np.any(chain > hi + tol):
        return False, "chain leaves R"
    rectangle = shapely.box(*lo, *hi)
    if np.any(shapely.distance(rectangle.exterior, shapely.points(chain[[0, -1]])) > tol):
        return False, "chain does not start and end on R's boundary"
    line = shapely.LineString(chain)
    if not line.is_simple:
        return False, "chain crosses itself"
    regions = [_even_odd(rings) for rings in cert.regions]
    if any(line.intersects(region) for region in regions):
        return False, "chain touches a projected object"
    # the chain's ends pushed out of R, so it cuts R's boundary cleanly
    ends = [_outward(chain[0], lo, hi, size), _outward(chain[-1], lo, hi, size)]
    pieces = split(rectangle, shapely.LineString(np.vstack([ends[0], chain, ends[1]]))).geoms
    if len(pieces) < 2:
        return False, "chain does not cut R"
    floor = 1e-12 * size * size
    for piece in pieces:
        if all(piece.intersection(region).area > floor for region in regions):
            return False, "an object reaches the other object's side"
    return True, "chain separates the objects"


def _even_odd(rings):
    """The region of polygon rings under the even-odd rule, as a shapely geometry."""
    import shapely

    region = shapely.Polygon()
    for ring in rings:
        region = region.symmetric_difference(shapely.make_valid(shapely.Polygon(ring)))
    return region


def _outward(point, lo, hi, size):
    """``point`` (on R's boundary) moved out of R across its nearest side."""
    gaps = np.array([point[0] - lo[0], hi[0] - point[0], point[1] - lo[1], hi[1] - point[1]])
    side = int(np.argmin(gaps))
    step = np.array([[-1.0, 0.0], [1.0, 0.0], [0.0, -1.0], [0.0, 1.0]])[side]
    return point + 1e-3 * size * step
