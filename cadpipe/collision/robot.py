"""A robot for collision checks: links with collision meshes on a joint tree.

URDF files are parsed by yourdfpy (a well-kept loader); ``package://`` mesh
references are resolved by :mod:`cadpipe.collision.packages`. Link collision
geometry (meshes, boxes, cylinders, spheres, each with its origin) is merged
into one closed mesh per link with manifold3d. A collision mesh that is not a
closed solid (stock robot models ship many) is replaced by its convex hull, a
conservative stand-in, or kept as given (then nothing can be found inside that
link); :attr:`Robot.notes` says which, per link. Forward kinematics is a
product of 4x4 matrices down the tree, for every frame of the URDF, so posing
the arm costs a few matrix products.

Allowed pairs follow MoveIt: links joined by a joint are allowed by default
(skipping links without geometry, e.g. a flange frame), and an SRDF file's
``disable_collisions`` entries are added with their reasons.
"""

from dataclasses import dataclass
from pathlib import Path as FilePath

import numpy as np

from cadpipe.errors import InputError, MeshError, SpecError
from cadpipe.geometry.mesh import Mesh
from cadpipe.collision import kinematics

MOVING = ("revolute", "continuous", "prismatic")


@dataclass(frozen=True)
class Joint:
    """One joint: ``child`` sits at ``parent @ origin @ motion(value)``, the motion
    a rotation about ``axis`` (revolute, continuous), a shift along it
    (prismatic) or nothing (fixed)."""

    name: str
    kind: str                  # revolute, continuous, prismatic or fixed
    parent: str
    child: str
    origin: np.ndarray         # 4x4
    axis: np.ndarray           # unit 3-vector
    lower: float = -np.inf
    upper: float = np.inf
    mimic: tuple = None        # (joint name, multiplier, offset)


class Robot:
    """A tree of links and joints with one collision mesh per link that has geometry.

    Parameters
    ----------
    name : str
    joints : sequence of :class:`Joint`
        In any order; they must form a tree.
    link_meshes : mapping of link name -> Mesh
        Collision geometry in each link's frame (links without geometry omitted).
    allowed : sequence of (link, link, reason), optional
        Extra allowed pairs (e.g. from an SRDF); adjacent links are added here.
    open_links : collection of str, optional
        Links whose mesh is an open surface kept as given: they collide by
        their triangles, and nothing is found inside them.
    notes : mapping of link name -> str, optional
        How each link's geometry was made from its file (see :attr:`notes`).
    """

    def __init__(self, name, joints, link_meshes, allowed=(), open_links=(), notes=None):
        self.name = str(name)
        self.open_links = frozenset(open_links)
        self.link_meshes = {k: v if k in self.open_links else v.require_solid(f"link {k}")
                            for k, v in link_meshes.items()}
        #: per link with geometry: how its collision mesh was made (convex hull of an
        #: open mesh, kept open, faces flipped), empty where it was used as given
        self.notes = dict(notes or {})
        children = {j.child for j in joints}
        parents = {j.parent for j in joints}
        roots = (parents | set(self.link_meshes)) - children
        if len(roots) != 1:
            raise InputError(f"robot {name}: joints must form one tree, found roots "
                             f"{sorted(roots)}")
        self.base = roots.pop()
        by_parent = {}
        for j in joints:
            by_parent.setdefault(j.parent, []).append(j)
        order, todo = [], [self.base]
        while todo:                     # parents before children
            link = todo.pop()
            for j in by_parent.get(link, []):
                order.append(j)
                todo.append(j.child)
        self.joints = tuple(order)
        names = {j.name for j in order}
        for j in order:
            if j.mimic is not None and j.mimic[0] not in names:
                raise InputError(f"joint {j.name} mimics unknown joint {j.mimic[0]!r}")
        self.actuated = tuple(j.name for j in order if j.kind in MOVING and j.mimic is None)
        self._kinematics = _kinematics(order, self.base, self.link_meshes)
        self.frames = tuple(self._kinematics["links"])
        self.allowed_pairs = tuple(dict.fromkeys(
            [(a, b, "adjacent links") for a, b in self._adjacent()]
            + [(a, b, str(r)) for a, b, r in allowed if a in self.link_meshes
               and b in self.link_meshes]))

    @property
    def link_shapes(self):
        """What :meth:`CollisionWorld.add_robot` adds per link: the closed Mesh, or a
        :class:`~cadpipe.collision.bodies.Surface` for a link kept open."""
        from cadpipe.collision.bodies import Surface

        return {k: Surface(m) if k in self.open_links else m for k, m in self.link_meshes.items()}

    @property
    def limits(self):
        """``(2, A)`` lower and upper limits of the :attr:`actuated` joints (+-inf
        for continuous ones)."""
        return self._kinematics["limits"].copy()

    @property
    def default(self):
        """``(A,)`` the default configuration, as MoveIt sets it: 0 where 0 is
        within a joint's limits, else the middle of the limits (or the nearer
        limit of a half-open range)."""
        lower, upper = self.limits
        bounded = np.isfinite(lower) & np.isfinite(upper)
        middle = np.where(bounded, 0.5 * (np.where(bounded, lower, 0.0) + np.where(
            bounded, upper, 0.0)), np.clip(0.0, lower, upper))
        return np.where((lower <= 0.0) & (upper >= 0.0), 0.0, middle)

    def __repr__(self):
        return (f"<cadpipe Robot {self.name}: {len(self.link_meshes)} links with geometry, "
                f"{len(self.actuated)} joints>")

    def _adjacent(self):
        """Pairs of geometry links joined through links that have no geometry."""
        parent_of = {j.child: j.parent for j in self.joints}
        pairs = []
        for link in self.link_meshes:
            up = parent_of.get(link)
            while up is not None and up not in self.link_meshes:
                up = parent_of.get(up)
            if up is not None:
                pairs.append((up, link))
        return pairs

    # -- posing ------------------------------------------------------------------
    def joint_array(self, configurations):
        """Validate ``(C, A)`` joint values over :attr:`actuated` into ``(C, J)`` values
        of every joint in :attr:`joints` order (fixed joints 0, mimics derived).

        One configuration may also be an ``(A,)`` sequence, a mapping by name
        (missing names take :attr:`default`), or None for :attr:`default`.
        """
        k = self._kinematics
        q = self._checked_shape(configurations)
        q = q[None] if q.ndim == 1 else q
        values = np.empty((len(q), len(self.joints)))
        self._raise_outside(q, kinematics.joint_values(q, k["limits"], k["actuated"],
                                                       k["mimics"], k["mimic_terms"], values))
        return values

    def _checked_shape(self, configurations):
        """``(C, A)`` or ``(A,)`` float64 values: an array of the right dtype and
        shape as it is (the per-state path), anything else through
        :meth:`_as_values`."""
        q = configurations
        if type(q) is np.ndarray and q.dtype == np.float64 and q.ndim in (1, 2) \
                and q.shape[-1] == len(self.actuated) and q.flags.c_contiguous:
            return q
        return self._as_values(q)

    def _raise_outside(self, q, bad):
        """:class:`InputError` for the value at flat index ``bad`` of ``q`` (C, A)
        outside its limits (nothing for -1)."""
        if bad >= 0:
            c, a = divmod(bad, q.shape[1])
            lower, upper = self._kinematics["limits"][:, a]
            raise InputError(f"{self.actuated[a]}={float(q[c, a])!r} is outside its limits "
                             f"[{lower:g}, {upper:g}]", key="joints")

    def _as_values(self, configurations):
        """``(C, A)`` or ``(A,)`` float64 joint values from any accepted input, or
        :class:`InputError` saying what is wrong with it."""
        if configurations is None or hasattr(configurations, "items"):
            configurations = [self._from_mapping(configurations or {})]
        try:
            q = np.asarray(configurations, dtype=np.float64)
        except (TypeError, ValueError):
            raise InputError("expected numbers (radians or metres), got "
                             f"{configurations!r}", key="joints") from None
        if q.ndim not in (1, 2) or q.shape[-1] != len(self.actuated):
            raise InputError(f"robot {self.name} has {len(self.actuated)} joints "
                             f"({', '.join(self.actuated)}), got "
                             f"{q.shape[-1] if q.ndim else 1} values", key="joints")
        return np.ascontiguousarray(q)

    def _from_mapping(self, joints):
        unknown = set(joints) - set(self.actuated)
        if unknown:
            raise InputError(f"unknown joint {sorted(unknown)[0]!r}; robot "
                             f"{self.name} has {', '.join(self.actuated)}", key="joints")
        return [joints.get(name, value) for name, value in zip(self.actuated, self.default)]

    def link_pose_array(self, configurations, base=None):
        """World poses ``(C, L, 4, 4)`` of the links with geometry (in
        :attr:`link_meshes` order) at each of ``(C, A)`` joint configurations.

        Every joint's local transform is built at once (Rodrigues' formula,
        ``origin @ (I + sin K + (1 - cos) K^2)``, with the products by the origin
        precomputed), then multiplied down the tree, in one compiled call for all
        configurations (:func:`cadpipe.collision.kinematics.chain_poses`).
        """
        return self._frame_pose_array(self.joint_array(configurations), base,
                                      self._kinematics["geometry"])

    def all_frame_poses(self, configurations, base=None):
        """``(C, F, 4, 4)`` world poses of every frame of the URDF, in :attr:`frames`
        order (the base first, then each joint's child), at ``(C, A)`` joint
        configurations."""
        return self._frame_pose_array(self.joint_array(configurations), base,
                                      self._kinematics["frame_index"])

    def _frame_pose_array(self, q, base, frames):
        """``(C, F, 4, 4)`` poses of the frames ``frames`` (F,) (indices into
        :attr:`frames`) at ``(C, J)`` values of every joint."""
        k = self._kinematics
        base = _EYE if base is None else np.ascontiguousarray(base, np.float64)
        return kinematics.chain_poses(q, k["terms"], k["kinds"], k["joint_links"], base, frames)

    def frame_poses(self, configurations, frame, base=None):
        """World pose of ``frame`` (any link of the URDF, with or without geometry,
        e.g. ``"panda_hand_tcp"``) at joint configurations.

        Parameters
        ----------
        configurations : (C, A) or (A,) array, mapping or None
            Joint values over :attr:`actuated` (radians, metres).
        frame : str
            A name in :attr:`frames`.
        base : (4, 4) array, optional
            Where the robot's base stands (identity by default).

        Returns
        -------
        (C, 4, 4) array, or (4, 4) for one configuration given as ``(A,)``,
        a mapping or None.
        """
        try:
            at = self.frames.index(frame)
        except ValueError:
            raise InputError(f"frame {frame!r}: robot {self.name} has no such link; frames: "
                             + ", ".join(self.frames), key="frame") from None
        single = configurations is None or hasattr(configurations, "items") or \
            np.ndim(configurations) == 1
        poses = self._frame_pose_array(self.joint_array(configurations), base,
                                       np.array([at], np.int64))[:, 0]
        return poses[0] if single else poses

    def frame_path(self, configurations, frame, step, base=None, point=None):
        """The :class:`~cadpipe.Path` of ``frame``'s origin (or of a ``point`` fixed in it)
        over a joint trajectory, sampled so the polyline follows the motion within
        ``step / 2``: the centreline of a tool's safety pipe.

        Parameters
        ----------
        configurations : (C, A) array_like
            Joint values along the trajectory, radians or metres.
        frame : str
            The link or frame whose origin is followed.
        step : float
            Largest deviation allowed, doubled, in metres.
        base : (4, 4) array_like, optional
            Placement of the robot's base.
        point : (3,) array_like, optional
            A point in ``frame``'s coordinates to follow instead of its origin (a
            tool centre point).

        Returns
        -------
        path : Path
            See :func:`cadpipe.collision.trajectory.trajectory_points`.
        """
        from cadpipe.collision.trajectory import path_from_trajectory

        return path_from_trajectory(self, configurations, frame, step, base, point)

    def link_poses_at(self, joints=None, base=None):
        """``(L, 4, 4)`` world poses of the links with geometry at one configuration
        (a sequence over :attr:`actuated`, a mapping by name, or None): the batch
        of one of :meth:`link_pose_array`."""
        poses = np.empty((len(self.link_meshes), 4, 4))
        base = _EYE if base is None else np.ascontiguousarray(base, np.float64)
        self.place_links(joints, base, poses, np.zeros(len(poses), np.int64), 0)
        return poses

    def place_links(self, joints, base, poses, versions, start):
        """Pose the links with geometry at one configuration ``joints`` (as for
        :meth:`link_poses_at`) from ``base`` (4, 4) into rows ``start:start + L``
        of ``poses`` (N, 4, 4), counting one move in ``versions`` (N,) each: a
        scene's :meth:`~cadpipe.collision.CollisionWorld.set_joints` in one
        compiled call (:func:`cadpipe.collision.kinematics.place_links`).
        Nothing is written when a value is outside its limits."""
        k = self._kinematics
        q = self._checked_shape(joints)
        if q.ndim == 2 and len(q) != 1:
            raise InputError(f"one configuration of robot {self.name} expected, got "
                             f"{len(q)}; use link_pose_array() for many", key="joints")
        q = q.reshape(1, -1)
        self._raise_outside(q, kinematics.place_links(q, k["limits"], k["actuated"],
                                                      k["mimics"], k["mimic_terms"], k["terms"],
                                                      k["kinds"], k["joint_links"], base,
                                                      k["geometry"], poses, versions, start))

    def link_poses(self, joints=None, base=None):
        """World pose (4x4) of every link that has geometry, by link name."""
        return dict(zip(self.link_meshes, self.link_poses_at(joints, base)))

    # -- loading -----------------------------------------------------------------
    @classmethod
    def from_urdf(cls, urdf, srdf=None, package_dirs=None, open_meshes="hull"):
        """Load a URDF (and optionally MoveIt's SRDF for its disabled pairs).

        Parameters
        ----------
        urdf : path
            The URDF file.
        srdf : path, optional
            MoveIt's SRDF; its ``disable_collisions`` pairs are allowed.
        package_dirs : mapping of name -> folder, or sequence of folders, optional
            Where ``package://NAME/...`` meshes are looked for first; see
            :mod:`cadpipe.collision.packages` for the rest of the search.
        open_meshes : {"hull", "as given"}
            What a collision mesh that is not a closed solid becomes: its convex
            hull (the default: a closed solid that contains it, so checks stay
            conservative) or the open surface as given (it collides by its
            triangles; nothing is found inside it). Either way
            :attr:`notes` says so for the link.
        """
        import yourdfpy

        if open_meshes not in ("hull", "as given"):
            raise InputError(f"open_meshes must be 'hull' or 'as given', got {open_meshes!r}",
                             key="open_meshes")
        path = FilePath(urdf)
        root = _xml_root(path, "URDF")   # a clear error for bad XML (yourdfpy would log it)
        if root.tag != "robot" or not root.get("name") or root.find("link") is None:
            # example-robot-data's ur3.urdf is an empty <robot>: say what a URDF needs
            missing = [what for what, gone in (("name", not root.get("name")),
                                               ("<link>", root.find("link") is None)) if gone]
            found = f"a <{root.tag}>" if root.tag != "robot" else \
                f"a <robot> with no {' and no '.join(missing)}"
            raise SpecError("not a URDF robot: a URDF is a <robot name=...> holding at least "
                            f"one <link>, this is {found}", file=path)
        try:
            model = yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=False,
                                       build_collision_scene_graph=False)
        except Exception as exc:      # lxml and yourdfpy raise many types for bad files
            raise SpecError(f"not a readable URDF ({type(exc).__name__}: {exc})", file=path) \
                from None
        joints = [_joint(j) for j in model.robot.joints]
        meshes, notes, open_links, files = {}, {}, set(), {}
        for link in model.robot.links:
            parts = [_geometry(c, path, package_dirs, link.name, files)
                     for c in link.collisions]
            parts = [p for p in parts if p is not None]
            if parts:
                meshes[link.name], said, is_open = _link_mesh(parts, link.name, open_meshes)
                if said:
                    notes[link.name] = said
                if is_open:
                    open_links.add(link.name)
        if not meshes:
            raise SpecError("no link has collision geometry; nothing to check", file=path)
        allowed = srdf_disabled_pairs(srdf) if srdf is not None else ()
        return cls(model.robot.name, joints, meshes, allowed, open_links, notes)


def _kinematics(joints, base, geometry):
    """Per-joint arrays for :meth:`Robot.link_pose_array`: the origin, its products
    with the axis' cross-product matrix ``K`` and ``K^2`` (turning) and with the
    axis (sliding), (parent, child) link indices, the actuated joints' positions
    and limits, the mimics, and the link index of each link with geometry."""
    links = [base] + [j.child for j in joints]
    index = {link: i for i, link in enumerate(links)}
    position = {j.name: k for k, j in enumerate(joints)}
    actuated = [k for k, j in enumerate(joints) if j.kind in MOVING and j.mimic is None]
    axis = np.array([j.axis for j in joints]).reshape(-1, 3)
    origin = np.array([j.origin for j in joints]).reshape(-1, 4, 4)
    cross = np.zeros((len(joints), 4, 4))          # the axis' cross-product matrix
    cross[:, 0, 1], cross[:, 0, 2], cross[:, 1, 2] = -axis[:, 2], axis[:, 1], -axis[:, 0]
    cross -= np.swapaxes(cross, 1, 2)
    slide = np.zeros((len(joints), 4, 4))
    slide[:, :3, 3] = axis
    mimics = [(k, position[j.mimic[0]]) for k, j in enumerate(joints) if j.mimic]
    return {"links": links,
            # per joint: the origin and its products with K, K^2 and the slide (J, 4, 4, 4)
            "terms": np.ascontiguousarray(np.stack([origin, origin @ cross,
                                                    origin @ cross @ cross, origin @ slide],
                                                   axis=1)),
            # per joint: 1.0 where it turns, 1.0 where it slides (J, 2)
            "kinds": np.array([[j.kind in ("revolute", "continuous"), j.kind == "prismatic"]
                               for j in joints], float).reshape(-1, 2),
            # per joint: the (parent, child) link indices, parents first (J, 2)
            "joint_links": np.array([[index[j.parent], index[j.child]] for j in joints],
                                    np.int64).reshape(-1, 2),
            "actuated": np.array(actuated, np.int64),
            "limits": np.array([[joints[k].lower for k in actuated],
                                [joints[k].upper for k in actuated]], float).reshape(2, -1),
            # mimic joint positions and the joints they follow (M, 2), multipliers and
            # offsets (M, 2)
            "mimics": np.array(mimics, np.int64).reshape(-1, 2),
            "mimic_terms": np.array([j.mimic[1:] for j in joints if j.mimic],
                                    float).reshape(-1, 2),
            "geometry": np.array([index[link] for link in geometry], np.int64),
            "frame_index": np.arange(len(links), dtype=np.int64)}


_EYE = np.eye(4)


def _joint(j):
    if j.type not in MOVING + ("fixed",):
        raise SpecError(f"joint {j.name}: type {j.type!r} is not supported; use revolute, "
                        "continuous, prismatic or fixed")
    axis = np.array([1.0, 0.0, 0.0] if j.axis is None else j.axis, np.float64)
    length = np.linalg.norm(axis)
    if not length > 0:
        if j.type in MOVING:
            raise SpecError(f"joint {j.name}: a {j.type} joint needs a non-zero axis, got "
                            f"{j.axis!r}")
        axis, length = np.array([1.0, 0.0, 0.0]), 1.0      # a fixed joint's axis is unused
    axis /= length
    lower, upper = -np.inf, np.inf
    if j.limit is not None and j.type in ("revolute", "prismatic"):
        lower = -np.inf if j.limit.lower is None else float(j.limit.lower)
        upper = np.inf if j.limit.upper is None else float(j.limit.upper)
    mimic = None if j.mimic is None else (j.mimic.joint, float(j.mimic.multiplier or 1.0),
                                          float(j.mimic.offset or 0.0))
    origin = np.eye(4) if j.origin is None else np.asarray(j.origin, np.float64)
    return Joint(j.name, j.type, j.parent, j.child, origin, axis, lower, upper, mimic)


def _geometry(collision, urdf, package_dirs, link, files):
    """One collision element as ``(mesh, source)`` in its link's frame (None for a
    mesh of zero scale); ``files`` caches meshes read by path."""
    import trimesh

    g = collision.geometry
    if g.mesh is not None:
        from cadpipe.collision.packages import resolve

        filename = resolve(g.mesh.filename, urdf, package_dirs)
        if not filename.is_file():
            raise InputError(f"link {link}: collision mesh {g.mesh.filename} not found (looked "
                             f"at {filename})", key=f"links.{link}", file=urdf)
        if filename not in files:
            files[filename] = Mesh.load(filename)
        mesh, source = files[filename], filename.name
        if g.mesh.scale is not None:
            scale = np.broadcast_to(np.asarray(g.mesh.scale, np.float64), (3,))
            if not np.prod(scale) != 0:
                return None
            faces = mesh.faces if np.prod(scale) > 0 else mesh.faces[:, ::-1]
            mesh = Mesh(mesh.vertices * scale, faces)
    elif g.box is not None:
        mesh, source = Mesh.from_trimesh(trimesh.creation.box(extents=g.box.size)), "box"
    elif g.cylinder is not None:
        mesh, source = Mesh.from_trimesh(trimesh.creation.cylinder(
            radius=g.cylinder.radius, height=g.cylinder.length, sections=32)), "cylinder"
    elif g.sphere is not None:
        mesh, source = Mesh.from_trimesh(trimesh.creation.icosphere(
            subdivisions=2, radius=g.sphere.radius)), "sphere"
    else:
        raise SpecError(f"link {link}: unsupported collision geometry")
    origin = collision.origin
    return (mesh if origin is None else mesh.transformed(origin)), source


def _link_mesh(parts, link, open_meshes):
    """``(mesh, note, is_open)``: one mesh for a link's collision elements.

    Closed parts are unioned with manifold3d; an open or non-manifold part
    becomes its convex hull (``open_meshes="hull"``) or is kept as given, and
    the link then is one open mesh of all its parts, as FCL would take it.
    """
    import manifold3d

    solids, said, is_open = [], [], False
    for mesh, source in parts:
        if mesh.is_oriented and mesh.volume < 0:
            mesh = Mesh(mesh.vertices, mesh.faces[:, ::-1])
            said.append(f"{source}: faces pointed inward, flipped")
        if not mesh.is_oriented or mesh.volume <= 0:
            if open_meshes == "hull":
                mesh = _hull(mesh, link, source)
                said.append(f"{source}: not a closed solid, replaced by its convex hull "
                            "(contains it: conservative)")
            else:
                is_open = True
                said.append(f"{source}: not a closed solid, kept as given (collides by its "
                            "triangles; nothing is found inside it)")
        solids.append(mesh)
    if is_open:
        mesh = solids[0] if len(solids) == 1 else Mesh.concatenate(solids)
    elif len(solids) == 1:
        mesh = solids[0]
    else:
        mesh = Mesh.from_manifold(manifold3d.Manifold.batch_boolean(
            [p.to_manifold(f"link {link}") for p in solids], manifold3d.OpType.Add))
    return mesh, "; ".join(said), is_open


def _hull(mesh, link, source):
    """The convex hull of a mesh's vertices as a closed Mesh (manifold3d's hull,
    manifold by construction where qhull's triangulation may not be)."""
    import manifold3d

    hull = manifold3d.Manifold.hull_points(np.asarray(mesh.vertices, np.float64))
    if hull.is_empty() or hull.volume() <= 0:
        raise MeshError(f"link {link}: collision mesh {source} is flat (no volume) and open; "
                        "it has no solid hull. Use open_meshes='as given'")
    return Mesh.from_manifold(hull)


def _xml_root(path, what):
    """The root element of an XML file, or :class:`SpecError` saying why there is none."""
    from xml.etree import ElementTree

    if not path.is_file():
        raise SpecError(f"no such {what} file", file=path)
    try:
        return ElementTree.parse(path).getroot()
    except ElementTree.ParseError as exc:
        raise SpecError(f"not readable XML ({exc})", file=path) from None


def srdf_disabled_pairs(path):
    """``(link, link, reason)`` from an SRDF's ``disable_collisions`` entries."""
    path = FilePath(path)
    pairs = []
    for entry in _xml_root(path, "SRDF").iter("disable_collisions"):
        a, b = entry.get("link1"), entry.get("link2")
        if not a or not b:
            raise SpecError("disable_collisions needs link1 and link2", file=path)
        pairs.append((a, b, f"srdf: {entry.get('reason') or 'disabled'}"))
    return pairs
