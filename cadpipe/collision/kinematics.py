"""Forward kinematics down a joint tree as one compiled loop (numba).

:meth:`cadpipe.collision.Robot.link_pose_array` builds each joint's local
transform by Rodrigues' formula, ``origin @ (I + sin K + (1 - cos) K^2)`` plus
``shift * origin @ slide`` for prisms (the products with ``K``, ``K^2`` and the
slide precomputed per joint), and multiplies down the tree, parents first. In
numpy that is ~20 calls per batch, which for one configuration is nearly all
the cost of a state check's kinematics; here it is one call.
"""

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def chain_poses(values, origin, turn, turn2, slide, revolute, prismatic, parent, child,
                base, geometry):
    """World poses ``(C, G, 4, 4)`` of links ``geometry`` (G,) at joint values
    ``values`` (C, J).

    ``origin``, ``turn``, ``turn2``, ``slide`` (J, 4, 4) are each joint's origin and
    its products with the axis' cross-product matrix, its square and the axis
    slide; ``revolute``, ``prismatic`` (J,) 1.0 for joints of that kind; joint ``j``
    moves link ``child[j]`` relative to ``parent[j]`` (parents first); ``base``
    (4, 4) places link 0.
    """
    count, joints = values.shape
    links = joints + 1
    out = np.empty((count, len(geometry), 4, 4))
    pose = np.empty((links, 4, 4))
    local = np.empty((4, 4))
    for c in range(count):
        pose[0] = base
        for j in range(joints):
            angle = values[c, j] * revolute[j]
            shift = values[c, j] * prismatic[j]
            sin, cos = np.sin(angle), 1.0 - np.cos(angle)
            for r in range(4):
                for k in range(4):
                    local[r, k] = origin[j, r, k] + sin * turn[j, r, k] \
                        + cos * turn2[j, r, k] + shift * slide[j, r, k]
            up, down = pose[parent[j]], pose[child[j]]
            for r in range(4):
                for k in range(4):
                    down[r, k] = up[r, 0] * local[0, k] + up[r, 1] * local[1, k] \
                        + up[r, 2] * local[2, k] + up[r, 3] * local[3, k]
        for g in range(len(geometry)):
            out[c, g] = pose[geometry[g]]
    return out


@numba.njit(cache=True, nogil=True)
def joint_values(q, lower, upper, actuated, mimic, source, multiplier, offset, out):
    """Every joint's value ``out`` (C, J) from the actuated ones ``q`` (C, A): fixed
    joints 0, ``out[:, actuated] = q``, mimic joint ``mimic[m]`` at
    ``multiplier[m] * out[:, source[m]] + offset[m]`` (mimics in joint order, so a
    mimic of a mimic is derived after its source).

    Returns -1, or the flat index ``c * A + a`` of the first value outside
    ``[lower[a], upper[a]]`` (NaN included), 1e-9 of slack: one compiled pass
    where validating in numpy was ~10 calls on arrays of a few numbers.
    """
    count, actuators = q.shape
    for c in range(count):
        for j in range(out.shape[1]):
            out[c, j] = 0.0
        for a in range(actuators):
            v = q[c, a]
            if not (v >= lower[a] - 1e-9 and v <= upper[a] + 1e-9):
                return c * actuators + a
            out[c, actuated[a]] = v
        for m in range(len(mimic)):
            out[c, mimic[m]] = multiplier[m] * out[c, source[m]] + offset[m]
    return -1
