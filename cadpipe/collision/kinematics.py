"""Forward kinematics down a joint tree as one compiled loop (C, ``csrc/kinematics.c``).

:meth:`cadpipe.collision.Robot.link_pose_array` builds each joint's local
transform by Rodrigues' formula, ``origin @ (I + sin K + (1 - cos) K^2)`` plus
``shift * origin @ slide`` for prisms (the products with ``K``, ``K^2`` and the
slide precomputed per joint), and multiplies down the tree, parents first. In
numpy that is ~20 calls per batch, which for one configuration is nearly all
the cost of a state check's kinematics; here it is one call.

The per-joint arrays come packed (``terms``, ``kinds``, ``links``; the limits,
mimics and their terms likewise): :func:`place_links`, one state of
:meth:`CollisionWorld.set_joints` (validate, pose, write into the scene, count
the move), is one call. The kernels take exactly typed, C-ordered arrays
(``Robot._kinematics`` holds them so); they are called directly, without a
Python wrapper, since a state's whole kinematics costs about a microsecond.

``chain_poses(values, terms, kinds, links, base, geometry)``
    World poses ``(C, G, 4, 4)`` of links ``geometry`` (G,) at joint values
    ``values`` (C, J). ``terms`` (J, 4, 4, 4) holds per joint its origin and the
    origin's products with the axis' cross-product matrix, its square and the
    axis slide; ``kinds`` (J, 2) is 1.0 in column 0 for turning and in column 1
    for sliding joints; joint ``j`` moves link ``links[j, 1]`` relative to
    ``links[j, 0]`` (parents first); ``base`` (4, 4) places link 0.
``joint_values(q, limits, actuated, mimics, mimic_terms, out)``
    Every joint's value ``out`` (C, J) from the actuated ones ``q`` (C, A):
    fixed joints 0, ``out[:, actuated] = q``, mimic joint ``mimics[m, 0]`` at
    ``mimic_terms[m, 0] * out[:, mimics[m, 1]] + mimic_terms[m, 1]`` (mimics in
    joint order, so a mimic of a mimic is derived after its source). Returns -1,
    or the flat index ``c * A + a`` of the first value outside
    ``[limits[0, a], limits[1, a]]`` (NaN included), 1e-9 of slack.
``place_links(q, limits, actuated, mimics, mimic_terms, terms, kinds, links, base,``
``geometry, poses, versions, start)``
    One configuration ``q`` (1, A) validated and posed into a scene: link
    ``geometry[g]``'s world pose into ``poses[start + g]``, whose
    ``versions[start + g]`` counts one more move. Returns -1, or (as
    :func:`joint_values`) the index of the first value outside its limits, and
    then writes nothing.
"""

from cadpipe.core.kernels import native

chain_poses = native.chain_poses
joint_values = native.joint_values
place_links = native.place_links

__all__ = ["chain_poses", "joint_values", "place_links"]
