"""Generalized winding numbers from a box tree, exact, without a pass over every triangle.

The winding number of a triangle set at a point is the sum of the triangles'
signed solid angles over 4 pi (Van Oosterom and Strackee's formula for each):
1 inside a closed outward mesh, 0 outside, fractions around holes. Two exact
ways to it walk the same :class:`~cadpipe.core.tree.BoxTree` (Morton order):

* A closed surface (every edge walked as often each way: no boundary at all)
  has an integer winding number off the surface, the signed count of its
  triangles that any ray from the point crosses (+1 leaving along the normal).
  The ray runs along the axis towards the nearest side of the mesh's box, and
  only the nodes whose boxes it meets are opened: about a microsecond a point
  at 1k to 100k triangles (docs/performance.md). Whether the ray passes an
  edge's one side or the other is computed the same, negated, for both faces of
  the edge, so each crossing is counted once; a ray within rounding of an edge
  or vertex, or a point within rounding of a crossing, is left to the sum below.
* Any triangle set: the solid angles summed down the tree. A node whose box does
  not contain the point is summed through its *cap* instead of its triangles
  (Jacobson, Kavan and Sorkine-Hornung 2013, section 3.3): the node's triangles
  ``C`` and the fan ``K`` from the box's centre over their boundary edges, turned
  the other way, form a closed surface inside the box, whose winding number at a
  point outside the box is 0; so ``w(C) = -w(K)`` exactly, and ``K`` has one
  triangle per boundary edge. A node is summed through whichever of its
  triangles and its cap is smaller; leaves and nodes whose box holds the point
  are summed triangle by triangle. Near a 6.4k-triangle helix pipe that is
  about 1,000 solid angles a point, not 6,396.

No far-field approximation is made (unlike Barill et al. 2018's dipoles): the
answers are the brute-force sum's up to rounding, for open meshes too. The
boundary edges are net directed edge counts (an edge walked twice one way and
once the other counts once), so non-manifold edges, degenerate triangles and
inconsistent windings need nothing special.
"""

from functools import cached_property

import numpy as np

from cadpipe.core.kernels import native
from cadpipe.core.tree import BoxTree


class WindingTree:
    """A triangle mesh prepared for winding numbers; see :meth:`__call__`.

    Parameters
    ----------
    vertices : (V, 3) float
    faces : (F, 3) int
        Indices into ``vertices``. Triangles that share an edge must share its
        vertex indices for their caps to be small (the answers do not depend on it).
    """

    def __init__(self, vertices, faces):
        vertices = np.ascontiguousarray(vertices, np.float64)
        faces = np.ascontiguousarray(faces, np.int64).reshape(-1, 3)
        corners = vertices[faces]
        self.tree = BoxTree.of_triangles(corners)
        self.vertices = vertices
        self.triangles = np.ascontiguousarray(corners[self.tree.order])      # tree order
        self.faces = np.ascontiguousarray(faces[self.tree.order])

    @classmethod
    def of_triangles(cls, triangles):
        """The tree of a triangle soup ``(F, 3, 3)``, its corners welded where their
        coordinates are equal."""
        triangles = np.asarray(triangles, np.float64).reshape(-1, 3, 3)
        vertices, faces = np.unique(triangles.reshape(-1, 3), axis=0, return_inverse=True)
        return cls(vertices, faces.reshape(-1, 3))

    @cached_property
    def closed(self):
        """Do the triangles form a closed surface (every edge walked as often each way,
        degenerate and non-manifold ones too), so that the winding number is an
        integer off the surface?"""
        # the edges walked low to high and those walked back, as vertex pairs, must be the
        # same multiset (csrc/winding.c sorts both)
        return self.tree.n > 0 and native.closed(self.faces, len(self.vertices))

    @cached_property
    def caps(self):
        """``(first, count, edges, times)``: every node's boundary, built when a point
        first needs the solid angles: for a 100k-triangle pipe 8 edges a triangle, 20
        MB, and 30 ms.

        Node ``k``'s boundary edges are rows ``first[k]:first[k] + count[k]`` of
        ``edges`` (E, 2), each ``(low, high)`` vertex pair walked ``times`` (E,) more
        often from low to high than back: leaves from their triangles, each node by
        merging its children's (both sorted by edge)."""
        return native.caps(self.faces, self.tree.leaves, self.tree.leaf_size,
                           len(self.vertices))

    def __call__(self, points):
        """Winding number of the triangles at each point.

        Parameters
        ----------
        points : (P, 3) float

        Returns
        -------
        winding : (P,) float
            The generalized winding number: the brute-force sum of solid angles over
            4 pi up to its rounding (``tests/test_winding.py`` holds them to 1e-9);
            off the surface of a closed mesh the exact integer (1 inside an outward
            mesh, 0 outside) wherever a ray decides it: all but points whose ray
            passes within about 1e-9 of the mesh's size of an edge, or that lie
            about that close to the surface, which get the sum.
        """
        points = np.ascontiguousarray(points, np.float64).reshape(-1, 3)
        out = np.zeros(len(points))
        if not self.tree.n:
            return out
        todo = np.arange(len(points))
        if self.closed:
            # the signed count of the triangles a ray from each point crosses (+1 where
            # it leaves along their normal), along the axis towards the nearest side of
            # the root box; ``unsure`` where the ray passes within rounding of an edge or
            # vertex, or a crossing is within rounding of the point
            unsure = np.zeros(len(points), np.bool_)
            native.crossings(points, self.tree.node_lo, self.tree.node_hi, self.triangles,
                             self.tree.leaf_size, out, unsure)
            todo = np.flatnonzero(unsure)
        if len(todo):
            # the solid angles summed down the tree, through a node's cap where its box
            # does not hold the point and the cap is the smaller
            exact = np.empty(len(todo))
            native.winding(np.ascontiguousarray(points[todo]), self.tree.node_lo,
                           self.tree.node_hi, self.triangles, *self.caps, self.vertices,
                           self.tree.leaf_size, exact)
            out[todo] = exact
        return out
