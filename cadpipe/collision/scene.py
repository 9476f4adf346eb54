"""What is where in a collision world: named bodies, their groups, rigid poses, allowed
pairs and the robots that pose links.

A :class:`Scene` changes only by explicit calls (``add``, ``allow``, ``set_pose``,
``add_robot``, ``set_joints``), and each change bumps a counter: ``layout_version``
when objects or allowed pairs are added, ``pose_versions[i]`` when object ``i`` moves.
Everything derived from it (:class:`~cadpipe.collision.checker.Checker`'s caches) is
keyed by those counters, so nothing can go stale.
"""

import numpy as np

from cadpipe.collision.bodies import as_body
from cadpipe.core.kernels import native
from cadpipe.core.transform import as_matrix
from cadpipe.errors import InputError


def _read_only(array):
    view = array.view()
    view.flags.writeable = False
    return view


def as_pose(transform, name):
    """A rigid 4x4 float matrix (the identity for None), or :class:`InputError`
    naming the object."""
    if transform is None:
        return np.eye(4)
    return as_poses(transform, name, shape=(4, 4))


def plain_pose(value):
    """Whether ``value`` is a float64 (4, 4) C-ordered array: what the compiled
    pose kernels take as it is (and check themselves)."""
    return type(value) is np.ndarray and value.shape == (4, 4) and \
        value.dtype == np.float64 and value.flags.c_contiguous


def as_poses(transforms, name, shape=None):
    """Rigid 4x4 float matrices ``(..., 4, 4)`` (exactly ``shape`` when given), or
    :class:`InputError` naming the object."""
    m = as_matrix(transforms, part=name, stack=True, rigid=True)
    if shape is not None and m.shape != shape:
        raise InputError(f"transform must be a 4x4 matrix, got shape {m.shape}", part=name,
                         key="transform")
    return m


# -- the scene -----------------------------------------------------------------------
class Scene:
    """Named meshes, pipes and primitives placed by rigid transforms: what is where.

    Changed only by :meth:`add`, :meth:`allow`, :meth:`set_pose`,
    :meth:`add_robot` and :meth:`set_joints`; ``layout_version`` counts the
    first two kinds of change, ``pose_versions`` (N,) each object's moves.
    """

    def __init__(self):
        self._names, self._index, self._bodies, self._groups = [], {}, [], []
        self._poses = np.zeros((0, 4, 4))
        self._pose_versions = np.zeros(0, np.int64)
        self._allowed = {}                 # (i, j) with i < j -> reason
        self._robots = {}                  # group -> (robot, base pose, object ids of links)
        self.layout_version = 0

    @property
    def pose_versions(self):
        """(N,) int: how often each object has moved (read-only view)."""
        return _read_only(self._pose_versions)

    @property
    def poses(self):
        """(N, 4, 4) float: where each object stands (read-only view; it follows every
        later move)."""
        return _read_only(self._poses)

    @property
    def bodies(self):
        """Each object's :class:`~cadpipe.collision.bodies.Body`, in its own frame."""
        return tuple(self._bodies)

    @property
    def groups(self):
        """Each object's group (None: in none)."""
        return tuple(self._groups)

    @property
    def allowed_index(self):
        """``{(i, j): reason}`` of the allowed pairs by object index, ``i < j``."""
        return dict(self._allowed)

    def index(self, name):
        """The index of object ``name`` (in :attr:`names` order); :class:`InputError`
        naming the objects there are otherwise."""
        return self._find(name)

    def add(self, name, obj, transform=None, group=None):
        """Add ``obj`` (a Mesh, Pipe, Box, Sphere or Capsule) under a new ``name``.

        Objects sharing a ``group`` are checked against each other as
        self-collision pairs; every object is checked against every other.
        """
        if not isinstance(name, str) or not name:
            raise InputError(f"object name must be a non-empty string, got {name!r}", key="name")
        if name in self._index:
            raise InputError("an object of that name is already in the world; "
                             "use set_pose() to move it or pick another name", part=name)
        pose = as_pose(transform, name)
        body = as_body(obj, name)
        self._index[name] = len(self._names)
        self._names.append(name)
        self._bodies.append(body)
        self._groups.append(None if group is None else str(group))
        self._poses = np.concatenate([self._poses, pose[None]])
        self._pose_versions = np.append(self._pose_versions, 0)
        self.layout_version += 1
        return self

    def _find(self, name):
        try:
            return self._index[name]
        except (KeyError, TypeError):
            known = ", ".join(self._names) or "none yet"
            raise InputError(f"unknown object {name!r}; objects in the world: {known}",
                             part=name if isinstance(name, str) else None) from None

    @property
    def names(self):
        return tuple(self._names)

    def group(self, name):
        return self._groups[self._find(name)]

    def pose(self, name):
        return self._poses[self._find(name)].copy()

    def body(self, name):
        """The :class:`~cadpipe.collision.bodies.Body` of ``name`` (in its own frame)."""
        return self._bodies[self._find(name)]

    def set_pose(self, name, transform):
        """Move object ``name`` to a new rigid 4x4 ``transform``."""
        i = self._find(name)
        # a float64 4x4 array is checked and written in one compiled call; anything
        # else, and any matrix that fails, goes through as_pose (and its message)
        if not (plain_pose(transform)
                and native.set_pose(transform, self._poses, self._pose_versions, i) == 0):
            self._moved(i, as_pose(transform, name))

    def _moved(self, ids, poses):
        self._poses[ids] = poses
        self._pose_versions[ids] += 1

    def allow(self, a, b, reason="allowed by user"):
        """Never report the pair ``a``, ``b`` (e.g. links joined by a joint)."""
        i, j = sorted((self._find(a), self._find(b)))
        if i == j:
            raise InputError(f"allow({a!r}, {b!r}): an object cannot collide with itself",
                             part=a)
        self._allowed[(i, j)] = str(reason)
        self.layout_version += 1

    @property
    def allowed(self):
        """``(name_a, name_b, reason)`` for every allowed pair, in the objects' order
        (a list, as :attr:`CollisionReport.allowed`)."""
        return [(self._names[i], self._names[j], r)
                for (i, j), r in sorted(self._allowed.items())]

    def add_robot(self, robot, joints=None, transform=None, group=None):
        """Add each link of a :class:`~cadpipe.collision.Robot` with geometry, posed by
        ``joints``; the robot's allowed pairs (adjacent links, SRDF) come along.

        Links are named by their link names, in group ``group`` (default: the
        robot's name), so :meth:`set_joints` and :meth:`check_path` can move
        them later.
        """
        group = robot.name if group is None else str(group)
        if group in self._robots:
            raise InputError(f"a robot with group {group!r} is already in the world; "
                             "pass another group=", key="group")
        base = as_pose(transform, f"robot {robot.name}")
        shapes = robot.link_shapes
        for link, pose in robot.link_poses(joints, base).items():
            self.add(link, shapes[link], transform=pose, group=group)
        for a, b, reason in robot.allowed_pairs:
            self.allow(a, b, reason)
        self._robots[group] = (robot, base, np.array([self._index[k] for k in robot.link_meshes]))
        return self

    def robot(self, group):
        """``(robot, base pose)`` of the robot added as ``group``."""
        robot, base, _ = self.robot_links(group)
        return robot, base.copy()

    def robot_links(self, group):
        """``(robot, base pose, (L,) object index of each link with geometry)`` of the
        robot added as ``group``: the objects its configurations move."""
        if group not in self._robots:
            raise InputError(f"no robot in group {group!r}; robots: {', '.join(self._robots)}",
                             key="group")
        return self._robots[group]

    def set_joints(self, group, joints):
        """Re-pose the links of the robot added as ``group`` (one configuration: a
        sequence over ``robot.actuated`` or a mapping by joint name)."""
        robot, base, ids = self.robot_links(group)
        # the links were added one after another, from ids[0] on
        robot.place_links(joints, base, self._poses, self._pose_versions,
                          int(ids[0]) if len(ids) else 0)


