"""Step S3 for a batch of tubes: frames, mitered ring axes and ring vertices.

A :class:`Tubes` holds any number of tubes (the pipes of a splice, or their
transitions) as concatenated per-point arrays (see :mod:`cadpipe.geometry.ragged`), so
every stage from tangents to ring axes is a fixed number of numpy calls for the
whole batch. A single :class:`~cadpipe.geometry.pipe.Pipe` is a batch of one.
"""

from functools import cached_property, lru_cache

import numpy as np

from cadpipe.geometry import buffers, clearance
from cadpipe._vec import cross, dot
from cadpipe.geometry.frames import frames
from cadpipe.geometry.ragged import blocks


@lru_cache(maxsize=256)
def ring_basis(sides):
    """(sides, 3) rows ``[cos a, sin a, 1]``: times a ring's ``[axis_cos; axis_sin;
    centre]`` they give its vertices, counter-clockwise about the tangent."""
    a = 2 * np.pi * np.arange(sides) / sides
    basis = np.stack([np.cos(a), np.sin(a), np.ones_like(a)], axis=1)
    basis.flags.writeable = False
    return basis


class Tubes:
    """Tubes of regular n-gon rings along a batch of paths.

    Parameters
    ----------
    lines : Polylines
        The paths and their groups (one group per tube).
    ring_radii : (N,) array
        Distance of ring vertices from the axis (before miter stretch).
    sides : (G,) array of int
    miter_limit : (G,) array
    patent, normals, end_normals, gentle :
        Frame settings per tube, as :func:`cadpipe.geometry.frames.frames` takes them.
    """

    def __init__(self, lines, ring_radii, sides, miter_limit, *, patent=False, normals=None,
                 end_normals=None, gentle=False):
        self.lines = lines
        self.groups = lines.groups
        self.ring_radii = ring_radii
        self.sides = np.asarray(sides, dtype=np.int64)
        self.miter_limit = np.asarray(miter_limit, dtype=np.float64)
        self._frame_settings = dict(patent=patent, normals=normals, end_normals=end_normals,
                                    gentle=gentle)

    @cached_property
    def _frames(self):
        self.lines.require_no_folds()
        return frames(self.lines, self.lines.tangents, symmetry=2 * np.pi / self.sides,
                      **self._frame_settings)

    @property
    def normals(self):
        """(3, N) unit direction of each ring's vertex 0 (before miter stretch)."""
        return self._frames[0]

    @property
    def seam_shift(self):
        """(G,) see :func:`cadpipe.geometry.frames.frames`."""
        return self._frames[1]

    @property
    def miter_stretch(self):
        """(N,) factor ``1 / cos(turn / 2)`` by which each ring is stretched in its bend plane."""
        return self.lines.miter_stretch

    @cached_property
    def axes(self):
        """(N, 3, 3) per ring: the two vectors that map ``(cos a, sin a)`` to a vertex
        offset, then the ring's centre (see :func:`ring_basis`).

        Each ring is the circle of ``ring_radii`` in the plane normal to the
        tangent, stretched by :attr:`miter_stretch` along the bend direction so that
        it lies on both adjacent segments' cylinders.
        """
        lines = self.lines
        out = buffers.empty((self.groups.size, 3, 3))
        for rows in blocks(self.groups.size):
            n = self.normals[:, rows]
            b = cross(lines.tangents[:, rows], n, 0)
            m = lines.bend_directions[:, rows]
            extra = lines.miter_stretch[rows] - 1.0
            r = self.ring_radii[rows]
            out[rows, 0] = ((n + extra * dot(n, m, 0) * m) * r).T
            out[rows, 1] = ((b + extra * dot(b, m, 0) * m) * r).T
        out[:, 2] = lines.xyz.T
        return out

    def rings(self, rows, sides):
        """(len(rows), sides, 3) vertices of the rings at ``rows``: one batched matrix
        product."""
        return np.matmul(ring_basis(sides), self.axes[rows])

    def self_intersection_findings(self):
        """Per tube, a list of findings where it would cut through itself (see
        :mod:`cadpipe.geometry.clearance`)."""
        return clearance.tube_self_intersections(self)
