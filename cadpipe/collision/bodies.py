"""What the collision world stores per object: a body in its own frame.

A body is either a closed triangle mesh (checked through FCL's BVH, plus a
point-in-solid test for containment) or a chain of balls (a pipe, sphere or
capsule, checked analytically by :mod:`cadpipe.collision.capsules`). Either
way it carries the points its bounding volumes are built from, a local OBB and
the probe points used to detect one solid wholly inside another.
"""

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from cadpipe._validate import as_positive
from cadpipe.errors import InputError
from cadpipe.geometry.mesh import Mesh
from cadpipe.geometry.pipe import Pipe
from cadpipe.collision import bounds
from cadpipe.collision.capsules import Chain


@dataclass(frozen=True)
class Box:
    """A solid box of ``size`` (x, y, z), centred on its frame's origin."""

    size: tuple

    def __post_init__(self):
        object.__setattr__(self, "size", tuple(float(v) for v in
                                               as_positive(self.size, "box size", count=3)))


@dataclass(frozen=True)
class Sphere:
    """A solid ball of ``radius`` centred on its frame's origin."""

    radius: float

    def __post_init__(self):
        object.__setattr__(self, "radius", float(as_positive(self.radius, "sphere radius")))


@dataclass(frozen=True)
class Capsule:
    """A segment of ``length`` along z, centred on the origin, swept by a ball of
    ``radius`` (FCL's and URDF's convention)."""

    radius: float
    length: float

    def __post_init__(self):
        object.__setattr__(self, "radius", float(as_positive(self.radius, "capsule radius")))
        object.__setattr__(self, "length", float(as_positive(self.length, "capsule length")))


@dataclass(frozen=True)
class Surface:
    """An open (or non-manifold) triangle mesh checked as given: it collides by its
    triangles, and nothing is ever inside it (a stock robot's collision mesh)."""

    mesh: Mesh


def box_mesh(size):
    """The closed 12-triangle mesh of a centred box."""
    import trimesh

    return Mesh.from_trimesh(trimesh.creation.box(extents=size))


class Body:
    """A collision shape in its own frame; see :func:`as_body`."""

    def __init__(self, *, mesh=None, chain=None, closed=True):
        self.mesh = mesh
        self.chain = chain
        self.kind = "mesh" if mesh is not None else "chain"
        self.closed = closed            # False: a Surface, with no inside

    @cached_property
    def hull(self):
        """(H, 3) points whose padded hull contains the body, and (H,) padding."""
        if self.kind == "chain":
            return self.chain.centers, self.chain.radii
        from scipy.spatial import ConvexHull, QhullError

        vertices = self.mesh.vertices
        try:
            points = vertices[ConvexHull(vertices).vertices]
        except QhullError:             # flat meshes: every vertex is extreme enough
            points = vertices
        return points, np.zeros(len(points))

    @cached_property
    def obb(self):
        """``(centre, axes, half_extents)`` in the body's frame."""
        return bounds.fit_obb(*self.hull)

    @cached_property
    def support(self):
        """Points and padding the world 18-DOP is computed from each pose: a chain's
        balls (exact); a mesh's hull vertices or, when fewer, the vertices of
        :func:`~cadpipe.collision.bounds.kdop_polytope` around them."""
        points, pad = self.hull
        if self.kind == "chain":
            # each ball once (a pipe's units share their end balls): the same slabs, from
            # half the points
            _, first = np.unique(np.c_[points, pad], axis=0, return_index=True)
            first.sort()
            return points[first], pad[first]
        polytope = bounds.kdop_polytope(points, self.obb)
        return (polytope, np.zeros(len(polytope))) if len(polytope) < len(points) \
            else (points, pad)

    @cached_property
    def local_kdop(self):
        """(2, 9) slabs of the body's hull on the 18-DOP directions, in its own frame."""
        points, pad = self.hull
        proj = points @ bounds.KDOP_DIRECTIONS.T
        return (proj - pad[:, None]).min(axis=0), (proj + pad[:, None]).max(axis=0)

    @cached_property
    def inside_filter(self):
        """``(lo, hi, low, high, slack)``: the mesh's box, its local 18-DOP slabs and
        the slack they are compared with, for the containment prefilter."""
        lo, hi = self.mesh.bounds
        low, high = self.local_kdop
        return lo, hi, low, high, 1e-9 * float(np.max(high - low))

    @cached_property
    def extremes(self):
        """(18, 3) points of the body farthest along each 18-DOP direction, both ways:
        a solid inside another has all of them inside the other's hull."""
        points, pad = self.hull
        directions = np.concatenate([bounds.KDOP_DIRECTIONS, -bounds.KDOP_DIRECTIONS])
        far = np.argmax(points @ directions.T + pad[:, None], axis=0)
        return points[far] + pad[far, None] * directions

    @cached_property
    def probes(self):
        """One point of each connected piece: if no boundaries touch, a piece is
        inside another solid exactly when its probe is."""
        if self.kind == "chain":
            return self.chain.centers[:1]
        labels = self.mesh.body_labels
        used = np.unique(self.mesh.faces)
        _, first = np.unique(labels[used], return_index=True)
        return self.mesh.vertices[used[first]]

    @cached_property
    def solid(self):
        """The mesh as a manifold3d solid (meshes only; for certificates)."""
        return self.mesh.to_manifold()

    @cached_property
    def fcl_geometry(self):
        """FCL's BVH of the mesh (meshes only)."""
        import fcl

        bvh = fcl.BVHModel()
        bvh.beginModel(len(self.mesh.vertices), len(self.mesh.faces))
        bvh.addSubModel(np.asarray(self.mesh.vertices), np.asarray(self.mesh.faces))
        bvh.endModel()
        return bvh

    @cached_property
    def fcl_anchor(self):
        """An FCL object of the BVH that stays at the identity: pairs are checked in
        this body's frame."""
        import fcl

        return fcl.CollisionObject(self.fcl_geometry, fcl.Transform())

    @cached_property
    def fcl_mover(self):
        """A second FCL object of the BVH, moved to the other body's relative pose."""
        import fcl

        return fcl.CollisionObject(self.fcl_geometry, fcl.Transform())

    @cached_property
    def triangle_tree(self):
        """The :class:`~cadpipe.collision.chain_mesh.TriangleTree` of the mesh (meshes
        only), walked against chains."""
        from cadpipe.collision.chain_mesh import TriangleTree

        return TriangleTree(self.mesh.vertices, self.mesh.faces)


def as_body(obj, name):
    """The :class:`Body` of a Mesh, Pipe, primitive or trimesh object.

    Meshes must be closed, outward solids (containment needs an inside);
    pipes become chains of round cones that contain their mesh
    (:meth:`~cadpipe.Pipe.collision_units`).
    """
    import trimesh

    if isinstance(obj, trimesh.Trimesh):
        obj = Mesh.from_trimesh(obj)
    if isinstance(obj, Mesh):
        return Body(mesh=obj.require_solid(name))
    if isinstance(obj, Surface):
        return Body(mesh=obj.mesh, closed=False)
    if isinstance(obj, Pipe):
        return Body(chain=Chain.of_units(*obj.collision_units()))
    if isinstance(obj, Box):
        return Body(mesh=box_mesh(obj.size))
    if isinstance(obj, Sphere):
        return Body(chain=Chain.along(np.zeros((1, 3)), obj.radius))
    if isinstance(obj, Capsule):
        half = np.array([[0.0, 0.0, -0.5 * obj.length], [0.0, 0.0, 0.5 * obj.length]])
        return Body(chain=Chain.along(half, obj.radius))
    raise InputError(f"cannot check a {type(obj).__name__} for collisions; "
                     "add a cadpipe Mesh, Pipe, Box, Sphere or Capsule", part=name)
