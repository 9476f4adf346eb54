"""Forward kinematics down a joint tree as one compiled loop (numba).

:meth:`cadpipe.collision.Robot.link_pose_array` builds each joint's local
transform by Rodrigues' formula, ``origin @ (I + sin K + (1 - cos) K^2)`` plus
``shift * origin @ slide`` for prisms (the products with ``K``, ``K^2`` and the
slide precomputed per joint), and multiplies down the tree, parents first. In
numpy that is ~20 calls per batch, which for one configuration is nearly all
the cost of a state check's kinematics; here it is one call.

The per-joint arrays come packed (``terms``, ``kinds``, ``links``; the limits,
mimics and their terms likewise), because numba checks every array argument
on every call: :func:`place_links`, one state of :meth:`CollisionWorld.set_joints`
(validate, pose, write into the scene, count the move), is one call with a
dozen arguments instead of two with twenty.
"""

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def chain_poses(values, terms, kinds, links, base, geometry):
    """World poses ``(C, G, 4, 4)`` of links ``geometry`` (G,) at joint values
    ``values`` (C, J).

    ``terms`` (J, 4, 4, 4) holds per joint its origin and the origin's products
    with the axis' cross-product matrix, its square and the axis slide;
    ``kinds`` (J, 2) is 1.0 in column 0 for turning and in column 1 for sliding
    joints; joint ``j`` moves link ``links[j, 1]`` relative to ``links[j, 0]``
    (parents first); ``base`` (4, 4) places link 0.
    """
    count, joints = values.shape
    out = np.empty((count, len(geometry), 4, 4))
    pose = np.empty((joints + 1, 4, 4))
    local = np.empty((4, 4))
    for c in range(count):
        pose[0] = base
        for j in range(joints):
            angle = values[c, j] * kinds[j, 0]
            shift = values[c, j] * kinds[j, 1]
            sin, cos = np.sin(angle), 1.0 - np.cos(angle)
            term = terms[j]
            for r in range(4):
                for k in range(4):
                    local[r, k] = term[0, r, k] + sin * term[1, r, k] \
                        + cos * term[2, r, k] + shift * term[3, r, k]
            up, down = pose[links[j, 0]], pose[links[j, 1]]
            for r in range(4):
                for k in range(4):
                    down[r, k] = up[r, 0] * local[0, k] + up[r, 1] * local[1, k] \
                        + up[r, 2] * local[2, k] + up[r, 3] * local[3, k]
        for g in range(len(geometry)):
            out[c, g] = pose[geometry[g]]
    return out


@numba.njit(cache=True, nogil=True)
def joint_values(q, limits, actuated, mimics, mimic_terms, out):
    """Every joint's value ``out`` (C, J) from the actuated ones ``q`` (C, A): fixed
    joints 0, ``out[:, actuated] = q``, mimic joint ``mimics[m, 0]`` at
    ``mimic_terms[m, 0] * out[:, mimics[m, 1]] + mimic_terms[m, 1]`` (mimics in
    joint order, so a mimic of a mimic is derived after its source).

    Returns -1, or the flat index ``c * A + a`` of the first value outside
    ``[limits[0, a], limits[1, a]]`` (NaN included), 1e-9 of slack: one compiled
    pass where validating in numpy was ~10 calls on arrays of a few numbers.
    """
    count, actuators = q.shape
    for c in range(count):
        for j in range(out.shape[1]):
            out[c, j] = 0.0
        for a in range(actuators):
            v = q[c, a]
            if not (v >= limits[0, a] - 1e-9 and v <= limits[1, a] + 1e-9):
                return c * actuators + a
            out[c, actuated[a]] = v
        for m in range(len(mimics)):
            out[c, mimics[m, 0]] = mimic_terms[m, 0] * out[c, mimics[m, 1]] + mimic_terms[m, 1]
    return -1


@numba.njit(cache=True, nogil=True)
def place_links(q, limits, actuated, mimics, mimic_terms, terms, kinds, links, base,
                geometry, poses, versions, start):
    """One configuration ``q`` (1, A) validated and posed into a scene: link
    ``geometry[g]``'s world pose into ``poses[start + g]``, whose
    ``versions[start + g]`` counts one more move. Returns -1, or (as
    :func:`joint_values`) the index of the first value outside its limits, and
    then writes nothing."""
    values = np.empty((1, len(kinds)))
    bad = joint_values(q, limits, actuated, mimics, mimic_terms, values)
    if bad >= 0:
        return bad
    found = chain_poses(values, terms, kinds, links, base, geometry)
    for g in range(len(geometry)):
        poses[start + g] = found[0, g]
        versions[start + g] += 1
    return -1
