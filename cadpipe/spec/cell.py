"""A robot cell from a spec file: the :class:`CollisionWorld` that ``cadpipe collide`` checks.

Spec files are read in one place, :func:`cadpipe.spec.reader.read`; a cell is a spec whose
added parts are the collision objects, with an optional ``robot``, ``allow`` and
``check`` (see ``docs/spec.md``). This module only turns the read spec into
:class:`CollisionWorld` calls.
"""

from cadpipe.solids.booleans import carve
from cadpipe.geometry.pipe import Pipe
from cadpipe.errors import CadpipeError
from cadpipe.spec.reader import Spec, read
from cadpipe.core.transform import is_rigid
from cadpipe.collision.world import CollisionWorld


def collision_shape(part):
    """``(shape, pose)`` of one assembly part for :meth:`CollisionWorld.add`.

    A plain :class:`~cadpipe.Pipe` stays a Pipe, checked analytically as the round
    tube along its path; anything else is checked as its own closed mesh (a hollow
    part as its wall: outer solids minus its own bores). Other parts' cuts
    (``subtract``, ``intersect``, bores) are not applied, so the check is
    conservative. A transform that scales or mirrors is baked into the mesh, since
    a collision pose must be rigid.
    """
    obj, pose = part.obj, part.transform
    rigid = pose is None or is_rigid(pose)
    if isinstance(obj, Pipe) and rigid:
        return obj, pose
    solids, bores = part.shapes()
    mesh = solids[0] if len(solids) == 1 and not bores else carve(solids, bores, part.name)
    return (mesh, pose) if rigid else (mesh.transformed(pose), None)


def world_from_spec(spec):
    """The :class:`CollisionWorld` of a spec (a :class:`~cadpipe.spec.reader.Spec` or a file).

    The robot's links come first (group ``robot.group``, with their adjacent and
    SRDF pairs allowed), then every added part under its name, then the ``allow``
    pairs. Check it with ``world.check(**spec.cell.check)``.
    """
    spec = spec if isinstance(spec, Spec) else read(spec)
    cell, world = spec.cell, CollisionWorld()
    if cell.robot is not None:
        posed = cell.robot
        world.add_robot(posed.robot, posed.joints, posed.transform, posed.group)
    for part in spec.assembly.parts:
        if part.name in cell.objects:
            try:
                world.add(part.name, *collision_shape(part))
            except CadpipeError as exc:          # at the part's key, as reading errors are
                raise spec.locate(exc.at(part=part.name)) from exc.__cause__
    for a, b, reason in cell.allow:
        world.allow(a, b, reason)
    return world
