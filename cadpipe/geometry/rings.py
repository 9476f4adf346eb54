"""Step S3 for a batch of tubes: frames, mitered ring axes and ring vertices.

A :class:`Tubes` holds any number of tubes (the pipes of a splice, or their
transitions) as concatenated per-point arrays (see :mod:`cadpipe.geometry.ragged`), so
every stage from tangents to ring axes is a fixed number of numpy calls for the
whole batch. A single :class:`~cadpipe.geometry.pipe.Pipe` is a batch of one.
"""

from functools import cached_property, lru_cache

import numpy as np

from cadpipe.geometry import buffers, clearance
from cadpipe.core.vec import cross, dot
from cadpipe.geometry.frames import frames
from cadpipe.geometry.path import REVERSAL
from cadpipe.geometry.ragged import blocks


@lru_cache(maxsize=256)
def ring_basis(sides):
    """(sides, 3) rows ``[cos a, sin a, 1]``: times a ring's ``[axis_cos; axis_sin;
    centre]`` they give its vertices, counter-clockwise about the tangent."""
    a = 2 * np.pi * np.arange(sides) / sides
    basis = np.stack([np.cos(a), np.sin(a), np.ones_like(a)], axis=1)
    basis.flags.writeable = False
    return basis


def square_rings(centres, directions, radii, sides):
    """(P, sides, 3) regular polygons of circumradius ``radii`` (P,) about ``centres``
    (P, 3), in the planes across the unit ``directions`` (P, 3): a tube's section cut
    square to its segment, where no ring of its own is there (a ball joint's)."""
    d = np.asarray(directions, np.float64)
    helper = np.zeros_like(d)
    helper[np.arange(len(d)), np.argmin(np.abs(d), axis=1)] = 1.0
    e1 = np.cross(d, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    axes = np.stack([e1 * radii[:, None], np.cross(d, e1) * radii[:, None], centres], axis=1)
    return np.matmul(ring_basis(sides), axes)


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

    def with_radii(self, ring_radii):
        """These tubes with other ring radii: the same paths and frames (a bore's)."""
        out = Tubes(self.lines, ring_radii, self.sides, self.miter_limit,
                    **self._frame_settings)
        if "_frames" in self.__dict__:
            out.__dict__["_frames"] = self._frames
        return out

    @cached_property
    def _frames(self):
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
    def over_limit(self):
        """(N,) True at corners beyond their tube's miter limit, and wherever a path
        reverses: these turn round in a ball joint (the swept solid), not a miter."""
        lines = self.lines
        return (lines.miter_stretch > self.miter_limit[self.groups.index]) | (
            lines.turning_angles > REVERSAL)

    @cached_property
    def axes(self):
        """(N, 3, 3) per ring: the two vectors that map ``(cos a, sin a)`` to a vertex
        offset, then the ring's centre (see :func:`ring_basis`).

        Each ring is the circle of ``ring_radii`` in the plane normal to the
        tangent, stretched by :attr:`miter_stretch` along the bend direction so that
        it lies on both adjacent segments' cylinders. Where the path reverses the
        ring is left unstretched: it is never laid out (a ball joint turns the tube).
        """
        lines = self.lines
        out = buffers.empty((self.groups.size, 3, 3))
        for rows in blocks(self.groups.size):
            n = self.normals[:, rows]
            b = cross(lines.tangents[:, rows], n, 0)
            m = lines.bend_directions[:, rows]
            stretch = lines.miter_stretch[rows]
            extra = np.where(np.isfinite(stretch), stretch, 1.0) - 1.0
            r = self.ring_radii[rows]
            out[rows, 0] = ((n + extra * dot(n, m, 0) * m) * r).T
            out[rows, 1] = ((b + extra * dot(b, m, 0) * m) * r).T
        out[:, 2] = lines.xyz.T
        return out

    def rings(self, rows, sides):
        """(len(rows), sides, 3) vertices of the rings at ``rows``: one batched matrix
        product."""
        return np.matmul(ring_basis(sides), self.axes[rows])

    def folds(self, first_only=False):
        """Per tube, its :class:`~cadpipe.geometry.clearance.Folds` (see
        :func:`cadpipe.geometry.clearance.tube_folds`); the full answer is kept."""
        if "_folds" in self.__dict__:
            return self.__dict__["_folds"]
        folds = clearance.tube_folds(self, first_only=first_only)
        if not first_only:
            self.__dict__["_folds"] = folds
        return folds

    def self_intersection_findings(self):
        """Per tube, a list of findings where it would cut through itself (see
        :mod:`cadpipe.geometry.clearance`)."""
        return [list(f.messages) for f in self.folds()]
