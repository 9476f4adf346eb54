"""Step S33: stitching rings of vertices into triangle surfaces.

Rings are stored one after another in a vertex array, ``sides`` vertices each,
counter-clockwise about the direction of travel. The functions here only make
face index arrays, so every surface built from rings (pipe sides, caps, splice
transitions) shares one orientation rule: faces point away from the axis.
:class:`Surface` lays a surface's blocks out and writes them straight into one
vertex and one face array.
"""

from functools import lru_cache, partial

import numpy as np

from cadpipe.geometry import buffers
from cadpipe.geometry.ragged import Groups
from cadpipe.geometry.rings import ring_basis


@lru_cache(maxsize=256)
def _band_pattern(sides):
    """(1, 6 * sides) side faces between ring 0 and ring 1 (vertices ``0..2*sides-1``),
    flattened: each quad (a, b, d, c) as triangles (a, b, c), (b, d, c). Every band
    is this one shifted by whole rings."""
    k = np.arange(sides)
    k1 = (k + 1) % sides
    tri = np.stack([np.stack([k, k1, k + sides], 1), np.stack([k1, k1 + sides, k + sides], 1)],
                   1).reshape(1, -1)
    tri.flags.writeable = False
    return tri


def fan_faces(ring_start, sides, *, apex=None, at_end=False):
    """Cap faces closing one ring: a fan from its vertex 0, or to an ``apex`` vertex.

    A cap at the start of a tube faces backwards, one at the end forwards.
    """
    k = np.arange(sides)
    if apex is None:
        k = k[1:-1]
        tri = np.stack([np.zeros_like(k), k, k + 1], 1) + ring_start
    else:
        tri = np.stack([np.full(sides, apex), k + ring_start, (k + 1) % sides + ring_start], 1)
    return tri if at_end else tri[:, ::-1]


@lru_cache(maxsize=4096)
def zipper_pattern(n_a, n_b, b_offset):
    """:func:`zipper_faces` for one ring pair, ring A numbered ``0..n_a-1`` and ring B
    ``n_a..n_a+n_b-1``."""
    mid_a = (np.arange(n_a) + 0.5) / n_a
    mid_b = ((np.arange(n_b) + 0.5 + b_offset) / n_b) % 1.0
    first_b = int(np.argmin(mid_b))                   # the B vertex current at angle 0
    mid_b = np.roll(mid_b, -first_b)
    is_a = np.concatenate([np.ones(n_a, bool), np.zeros(n_b, bool)])
    order = np.lexsort((~is_a, np.concatenate([mid_a, mid_b])))   # by angle, A first on ties
    is_a = is_a[order]
    a_cur = np.cumsum(is_a) - is_a                    # A edges passed before each event
    b_cur = np.cumsum(~is_a) - ~is_a
    a0, a1 = a_cur % n_a, (a_cur + 1) % n_a
    b0 = n_a + (first_b + b_cur) % n_b
    b1 = n_a + (first_b + b_cur + 1) % n_b
    faces = np.where(is_a[:, None], np.stack([a0, a1, b0], 1), np.stack([a0, b1, b0], 1))
    faces.flags.writeable = False
    return faces


def zipper_faces(a_start, n_a, b_start, n_b, b_offset):
    """Faces joining each ring A (upstream) to its ring B (downstream), of any sizes.

    All arguments are ``(Z,)`` arrays, one entry per ring pair. Vertex ``i`` of A
    sits at angle ``2*pi*i/n_a`` and vertex ``j`` of B at ``2*pi*(j + b_offset)/n_b``
    about the common axis. Walking both rings in angle order, each A edge gets one
    triangle to the current B vertex and each B edge one to the current A vertex:
    ``n_a + n_b`` triangles per pair, every vertex used. When ``n_b`` is a multiple
    of ``n_a`` and the rings are aligned, this is the source's n-to-1 stitch: each A
    vertex fans over ``n_b / n_a`` B edges. Pairs of equal sizes and offset share one
    pattern, so a chain of a thousand stitches costs a few numpy calls.
    """
    n_a, n_b = np.asarray(n_a), np.asarray(n_b)
    local = np.concatenate([zipper_pattern(*key) for key in
                            zip(n_a.tolist(), n_b.tolist(), np.asarray(b_offset).tolist())])
    sizes = n_a + n_b
    in_b = local >= np.repeat(n_a, sizes)[:, None]
    return local + np.where(in_b, np.repeat(np.asarray(b_start) - n_a, sizes)[:, None],
                            np.repeat(a_start, sizes)[:, None])


class Surface:
    """A triangle surface laid out block by block, then written in one pass.

    Each block reserves its rows now and gives a function that fills them later,
    so a surface of millions of vertices is written straight into its final
    arrays, with no concatenation. Runs of rings (:meth:`add_rings`) are laid out
    grouped by ring size, so a thousand pipes of a dozen sizes cost a dozen matrix
    products and face broadcasts. Face blocks may carry a part label (an index into
    :attr:`part_names`), as a splice's pipes and transitions do.
    """

    def __init__(self):
        self.vertex_count = 0
        self.face_count = 0
        self.part_names = []
        self._part_index = {}
        self._vertex_blocks = []
        self._face_blocks = []
        self._ring_runs = []

    def part(self, name):
        """The index of part ``name`` (added if new)."""
        if name not in self._part_index:
            self._part_index[name] = len(self.part_names)
            self.part_names.append(name)
        return self._part_index[name]

    def add_vertices(self, count, fill):
        """Reserve ``count`` vertices; ``fill(out)`` writes their ``(count, 3)`` rows.
        Returns the index of the first one."""
        first = self.vertex_count
        self._vertex_blocks.append((first, count, fill))
        self.vertex_count += count
        return first

    def add_faces(self, count, fill, part=None):
        """Reserve ``count`` faces; ``fill(out)`` writes their ``(count, 3)`` rows.
        ``part``: a part name, or a ``(count,)`` array of indices into ``part_names``."""
        if isinstance(part, str):
            part = self.part(part)
        self._face_blocks.append((self.face_count, count, fill, part))
        self.face_count += count

    def add_rings(self, runs, sides, parts=None, *, closed=None, seam_shift=None):
        """Lay out runs of rings and the side faces joining each run's rings.

        Parameters
        ----------
        runs : list of (n_i, 3, 3) arrays
            Each run's ring axes and centres (see :func:`~cadpipe.geometry.rings.ring_basis`).
        sides : (R,) array_like of int
            Vertices per ring of each run.
        parts : (R,) array_like of int, optional
            Part index of each run's faces.
        closed, seam_shift : (R,) array_like, optional
            Runs whose last ring joins their first, its vertex k meeting the first
            ring's vertex ``k + seam_shift``.

        Returns
        -------
        (R,) int array: the index of each run's first vertex.
        """
        sides = np.asarray(sides, dtype=np.int64)
        count = np.array([len(run) for run in runs], dtype=np.int64)
        closed = np.zeros(len(runs), bool) if closed is None else np.asarray(closed, bool)
        first = np.empty(len(runs), np.int64)
        for size in np.unique(sides).tolist():
            members = np.flatnonzero(sides == size)
            n = count[members]
            starts = self.vertex_count + size * (np.cumsum(n) - n)
            first[members] = starts
            self.add_vertices(int(n.sum()) * size, partial(
                _write_rings, [runs[i] for i in members.tolist()], size))
            bands = Groups(n - 1)
            band_first = bands.spread(starts) + size * bands.local()
            part = None if parts is None else np.repeat(
                np.asarray(parts, np.int32)[members], (n - 1) * 2 * size)
            self._ring_runs.append(np.column_stack([
                starts, n, np.full(len(n), size),
                self.face_count + 2 * size * (np.cumsum(n - 1) - (n - 1))]))
            self.add_faces(bands.size * 2 * size, partial(_write_bands, band_first, size), part)
        for i in np.flatnonzero(closed).tolist():
            self.add_faces(2 * int(sides[i]), partial(
                _write_seam, int(first[i]), int(count[i]), int(sides[i]),
                int(seam_shift[i])), None if parts is None else int(parts[i]))
        return first

    @property
    def ring_runs(self):
        """(G, 4) int64 runs of rings laid out by :meth:`add_rings`: each run's first vertex,
        ring count, sides and first side face (its bands' faces follow one another, ring
        ``j`` to ``j + 1`` as :func:`_band_pattern` shifted by ``j`` rings). A closed run's
        seam band is not among them."""
        return np.concatenate(self._ring_runs) if self._ring_runs else \
            np.empty((0, 4), np.int64)

    def build(self):
        """``(vertices, faces, face_part)``; ``face_part`` is None when no block has a part."""
        vertices = buffers.empty((self.vertex_count, 3))         # recycled memory: see buffers
        faces = buffers.empty((self.face_count, 3), np.int64)
        labelled = any(part is not None for *_, part in self._face_blocks)
        face_part = buffers.empty(self.face_count, np.int32) if labelled else None
        for first, count, fill in self._vertex_blocks:
            fill(vertices[first:first + count])
        for first, count, fill, part in self._face_blocks:
            fill(faces[first:first + count])
            if labelled:
                face_part[first:first + count] = part
        return vertices, faces, face_part


def _write_rings(runs, sides, out):
    """Ring vertices of same-size runs, one after another: a batched matrix product
    per run, straight into ``out`` (gathering the runs' axes first costs more)."""
    basis, rings, first = ring_basis(sides), out.reshape(-1, sides, 3), 0
    for axes in runs:
        np.matmul(basis, axes, out=rings[first:first + len(axes)])
        first += len(axes)


def _write_bands(band_first, sides, out):
    """Side faces of bands whose first ring starts at vertex ``band_first``."""
    np.add(band_first[:, None], _band_pattern(sides), out=out.reshape(len(band_first), 6 * sides))


def write_fan(ring, sides, apex, at_end, out):
    """:func:`fan_faces` written into ``out`` (a :class:`Surface` fill)."""
    out[:] = fan_faces(ring, sides, apex=apex, at_end=at_end)


def _write_seam(first, n_rings, sides, seam_shift, out):
    """The band closing a run of rings: its last ring back to its first."""
    k = np.arange(sides)
    k1 = (k + 1) % sides
    last = (n_rings - 1) * sides + first
    ks = (k + seam_shift) % sides + first
    ks1 = (k1 + seam_shift) % sides + first
    out[:] = np.concatenate([np.stack([last + k, last + k1, ks], 1),
                             np.stack([last + k1, ks1, ks], 1)])
