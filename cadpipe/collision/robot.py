"""A robot arm for collision checks: links with collision meshes on a joint tree.

URDF files are parsed by yourdfpy (a well-kept loader); link collision
geometry (meshes, boxes, cylinders, spheres, each with its origin) is merged
into one closed mesh per link with manifold3d. Forward kinematics is a product
of 4x4 matrices down the tree, so posing the arm costs a few matrix products.

Allowed pairs follow MoveIt: links joined by a joint are allowed by default
(skipping links without geometry, e.g. a flange frame), and an SRDF file's
``disable_collisions`` entries are added with their reasons.
"""

from dataclasses import dataclass
from pathlib import Path as FilePath

import numpy as np

from cadpipe.errors import InputError, MeshError, SpecError
from cadpipe.geometry.mesh import Mesh

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
    """

    def __init__(self, name, joints, link_meshes, allowed=()):
        self.name = str(name)
        self.link_meshes = {k: v.require_solid(f"link {k}") for k, v in link_meshes.items()}
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
        self.allowed_pairs = tuple(dict.fromkeys(
            [(a, b, "adjacent links") for a, b in self._adjacent()]
            + [(a, b, str(r)) for a, b, r in allowed if a in self.link_meshes
               and b in self.link_meshes]))

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
        (missing names stay 0), or None for all zeros.
        """
        if configurations is None or hasattr(configurations, "items"):
            configurations = [self._from_mapping(configurations or {})]
        try:
            q = np.asarray(configurations, dtype=np.float64)
        except (TypeError, ValueError):
            raise InputError("expected numbers (radians or metres), got "
                             f"{configurations!r}", key="joints") from None
        q = q[None] if q.ndim == 1 else q
        if q.ndim != 2 or q.shape[1] != len(self.actuated):
            raise InputError(f"robot {self.name} has {len(self.actuated)} joints "
                             f"({', '.join(self.actuated)}), got "
                             f"{q.shape[-1] if q.ndim else 1} values", key="joints")
        k = self._kinematics
        within = (q >= k["lower"] - 1e-9) & (q <= k["upper"] + 1e-9)    # NaN is not
        if not within.all():
            c, a = np.argwhere(~within)[0]
            raise InputError(f"{self.actuated[a]}={float(q[c, a])!r} is outside its limits "
                             f"[{k['lower'][a]:g}, {k['upper'][a]:g}]", key="joints")
        values = np.zeros((len(q), len(self.joints)))
        values[:, k["actuated"]] = q
        for j, source, multiplier, offset in k["mimics"]:
            values[:, j] = multiplier * values[:, source] + offset
        return values

    def _from_mapping(self, joints):
        unknown = set(joints) - set(self.actuated)
        if unknown:
            raise InputError(f"unknown joint {sorted(unknown)[0]!r}; robot "
                             f"{self.name} has {', '.join(self.actuated)}", key="joints")
        return [joints.get(name, 0.0) for name in self.actuated]

    def link_pose_array(self, configurations, base=None):
        """World poses ``(C, L, 4, 4)`` of the links with geometry (in
        :attr:`link_meshes` order) at each of ``(C, A)`` joint configurations.

        Every joint's local transform is built at once (Rodrigues' formula,
        ``origin @ (I + sin K + (1 - cos) K^2)``, with the products by the origin
        precomputed); then one stacked matrix product per joint walks down the
        tree, for all configurations together.
        """
        q = self.joint_array(configurations)
        k = self._kinematics
        angle, shift = (q * k["revolute"])[..., None, None], (q * k["prismatic"])[..., None, None]
        local = (k["origin"] + np.sin(angle) * k["turn"] + (1.0 - np.cos(angle)) * k["turn2"]
                 + shift * k["slide"])
        poses = np.empty((len(q), len(k["links"]), 4, 4))
        poses[:, 0] = np.eye(4) if base is None else base
        for step, (parent, child) in enumerate(k["edges"]):
            np.matmul(poses[:, parent], local[:, step], out=poses[:, child])
        return poses[:, k["geometry"]]

    def link_poses_at(self, joints=None, base=None):
        """``(L, 4, 4)`` world poses of the links with geometry at one configuration
        (a sequence over :attr:`actuated`, a mapping by name, or None): the batch
        of one of :meth:`link_pose_array`."""
        poses = self.link_pose_array(joints, base)
        if len(poses) != 1:
            raise InputError(f"one configuration of robot {self.name} expected, got "
                             f"{len(poses)}; use link_pose_array() for many", key="joints")
        return poses[0]

    def link_poses(self, joints=None, base=None):
        """World pose (4x4) of every link that has geometry, by link name."""
        return dict(zip(self.link_meshes, self.link_poses_at(joints, base)))

    # -- loading -----------------------------------------------------------------
    @classmethod
    def from_urdf(cls, path, srdf=None):
        """Load a URDF (and optionally MoveIt's SRDF for its disabled pairs)."""
        import yourdfpy

        path = FilePath(path)
        _xml_root(path, "URDF")       # a clear error for bad XML (yourdfpy would log it)
        try:
            urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=False,
                                      build_collision_scene_graph=False)
        except Exception as exc:      # lxml and yourdfpy raise many types for bad files
            raise SpecError(f"not a readable URDF ({type(exc).__name__}: {exc})", file=path) \
                from None
        joints = [_joint(j) for j in urdf.robot.joints]
        meshes = {}
        for link in urdf.robot.links:
            parts = [_geometry(c, path.parent, link.name) for c in link.collisions]
            if parts:
                meshes[link.name] = _union(parts, link.name)
        if not meshes:
            raise SpecError("no link has collision geometry; nothing to check", file=path)
        allowed = srdf_disabled_pairs(srdf) if srdf is not None else ()
        return cls(urdf.robot.name, joints, meshes, allowed)


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
    return {"links": links, "origin": origin, "turn": origin @ cross,
            "turn2": origin @ cross @ cross, "slide": origin @ slide,
            "revolute": np.array([j.kind in ("revolute", "continuous") for j in joints], float),
            "prismatic": np.array([j.kind == "prismatic" for j in joints], float),
            "edges": [(index[j.parent], index[j.child]) for j in joints],
            "actuated": np.array(actuated, np.int64),
            "lower": np.array([joints[k].lower for k in actuated]),
            "upper": np.array([joints[k].upper for k in actuated]),
            "mimics": [(k, position[j.mimic[0]], j.mimic[1], j.mimic[2])
                       for k, j in enumerate(joints) if j.mimic is not None],
            "geometry": [index[link] for link in geometry]}


def _joint(j):
    if j.type not in MOVING + ("fixed",):
        raise SpecError(f"joint {j.name}: type {j.type!r} is not supported; use revolute, "
                        "continuous, prismatic or fixed")
    axis = np.array([1.0, 0.0, 0.0] if j.axis is None else j.axis, np.float64)
    axis /= np.linalg.norm(axis)
    lower, upper = -np.inf, np.inf
    if j.limit is not None and j.type in ("revolute", "prismatic"):
        lower = -np.inf if j.limit.lower is None else float(j.limit.lower)
        upper = np.inf if j.limit.upper is None else float(j.limit.upper)
    mimic = None if j.mimic is None else (j.mimic.joint, float(j.mimic.multiplier or 1.0),
                                          float(j.mimic.offset or 0.0))
    origin = np.eye(4) if j.origin is None else np.asarray(j.origin, np.float64)
    return Joint(j.name, j.type, j.parent, j.child, origin, axis, lower, upper, mimic)


def _geometry(collision, folder, link):
    """One collision element as a Mesh in its link's frame."""
    import trimesh

    g = collision.geometry
    if g.mesh is not None:
        filename = g.mesh.filename
        if "://" in filename:              # package://name/rest -> rest, beside the URDF
            filename = filename.split("://", 1)[1].split("/", 1)[-1]
        mesh = Mesh.load(folder / filename)
        if g.mesh.scale is not None:
            scale = np.broadcast_to(np.asarray(g.mesh.scale, np.float64), (3,))
            faces = mesh.faces if np.prod(scale) > 0 else mesh.faces[:, ::-1]
            mesh = Mesh(mesh.vertices * scale, faces)
    elif g.box is not None:
        mesh = Mesh.from_trimesh(trimesh.creation.box(extents=g.box.size))
    elif g.cylinder is not None:
        mesh = Mesh.from_trimesh(trimesh.creation.cylinder(radius=g.cylinder.radius,
                                                           height=g.cylinder.length,
                                                           sections=32))
    elif g.sphere is not None:
        mesh = Mesh.from_trimesh(trimesh.creation.icosphere(subdivisions=2,
                                                            radius=g.sphere.radius))
    else:
        raise SpecError(f"link {link}: unsupported collision geometry")
    origin = collision.origin
    return mesh if origin is None else mesh.transformed(origin)


def _union(parts, link):
    """One closed mesh for a link's collision elements (a manifold3d union)."""
    if len(parts) == 1:
        return parts[0].require_solid(f"link {link}")
    import manifold3d

    try:
        solids = [p.to_manifold(f"link {link}") for p in parts]
    except MeshError as exc:
        raise MeshError(f"{exc} (link {link} collision geometry must be closed)") from None
    return Mesh.from_manifold(manifold3d.Manifold.batch_boolean(solids, manifold3d.OpType.Add))


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
