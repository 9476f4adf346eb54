"""The solids a CAD user expects beside pipes: box, cylinder, sphere, imported mesh.

Each is a closed, outward :class:`~cadpipe.Mesh` built by manifold3d, so it goes
into booleans as it is; ``attributes`` record the parameters that made it.
"""

import numpy as np

from cadpipe import limits
from cadpipe._validate import as_int, as_positive
from cadpipe.solids.booleans import snap
from cadpipe.errors import CadpipeError, InputError
from cadpipe.geometry.mesh import Mesh


def _from_manifold(solid, **attributes):
    return Mesh.from_manifold(solid, attributes=attributes)


def box(size, center=True):
    """A box of edge lengths ``size`` (one number for a cube, or three).

    Centred on the origin, or with its minimum corner there when ``center`` is False.
    """
    import manifold3d

    size = as_positive(size, "size", count=3)
    size = np.broadcast_to(size, (3,)).astype(float)
    return _from_manifold(manifold3d.Manifold.cube(tuple(size), bool(center)),
                          kind="box", size=size.tolist(), center=bool(center))


def cylinder(radius, height, sides=32, center=True):
    """A ``sides``-gon prism around the z axis, inscribed in a circle of ``radius``.

    Centred on the origin, or standing on the xy plane when ``center`` is False.
    """
    import manifold3d

    radius = float(as_positive(radius, "radius"))
    height = float(as_positive(height, "height"))
    sides = as_int(sides, "sides", low=3, high=4096)
    solid = manifold3d.Manifold.cylinder(height, radius, radius, sides, bool(center))
    return _from_manifold(solid, kind="cylinder", radius=radius, height=height, sides=sides,
                          center=bool(center))


def sphere(radius, segments=32):
    """A geodesic sphere centred on the origin with vertices on the sphere of ``radius``.

    ``segments`` is the number of edges around a great circle (rounded up to a
    multiple of four by manifold3d).
    """
    import manifold3d

    radius = float(as_positive(radius, "radius"))
    segments = as_int(segments, "segments", low=4, high=4096)
    limits.check("max_triangles", segments * segments // 2, f"a sphere of {segments} segments",
                 key="segments")
    return _from_manifold(manifold3d.Manifold.sphere(radius, segments), kind="sphere",
                          radius=radius, segments=segments)


def imported(path, snap_tolerance=None):
    """A closed solid read from a mesh file (STL, OBJ, PLY, GLB, 3MF, ... via trimesh).

    Near-duplicate vertices are welded (:func:`cadpipe.solids.booleans.snap`); raises
    :class:`~cadpipe.MeshError` naming the file when the result is not a closed,
    outward solid.
    """
    if snap_tolerance is not None:
        snap_tolerance = float(as_positive(snap_tolerance, "snap_tolerance"))
    mesh = snap(Mesh.load(path), snap_tolerance)
    if not len(mesh.faces):
        raise InputError("every triangle collapsed when welding vertices; "
                         "use a smaller snap_tolerance", file=path)
    try:
        mesh.require_solid(None)
    except CadpipeError as exc:
        raise exc.at(file=path) from None
    return mesh.with_attributes(kind="mesh")
