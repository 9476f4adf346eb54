"""Collision checks: cadpipe's CollisionWorld vs trimesh's CollisionManager (FCL).

Part 1, a robot cell: a 7-link arm of capsule-like links, a 20k-triangle
workpiece and 3 safety pipes, posed at 10,000 random joint configurations;
each configuration: re-pose the links and find every colliding pair.

* per call: ``set_joints`` + ``check()`` per configuration, against trimesh's
  manager per configuration (``link_poses`` + ``set_transform`` +
  ``in_collision_internal``): the same forward kinematics on both sides;
* batched: one ``check_path`` call for all configurations, against the same
  trimesh loop fed by one batched forward-kinematics call (its best case).

trimesh gets the pipes as meshes and has no allowed-collision matrix (it reports
the touching neighbours too, which are dropped before comparing answers);
cadpipe also finds links wholly inside the workpiece, which FCL cannot see.

Part 2, pipe vs pipe: two safety pipes at 10,000 random relative poses:
cadpipe's analytic chains (per pose, batched over all poses, and batched through
the whole ``check_many`` funnel) against the same pipes' meshes in FCL.

Part 3, the Panda cell (the URDF and SRDF of ``assets/robots/panda``, 35 allowed
pairs, 4 obstacles), one state at a time: cadpipe ``set_joints`` + ``check()``
(and ``first_hit=True``, with and without ``only="panda"``: the robot against
itself and the world, obstacle pairs left out) against MuJoCo (``mj_kinematics``
+ ``mj_collision``), pybullet (``resetJointState`` + ``performCollisionDetection``),
and python-fcl and coal loops over the same pairs that stop at the first hit.
Without ``only`` the obstacle pairs are decided on the first state and their
answers kept (their objects never move), so both modes decide them at most once.

Every figure is the median of ``--repeat`` runs, all methods of a part interleaved
in one process (A B A B ...) after one untimed round: the machine is shared, so
read the ratios. MuJoCo, pybullet and coal are optional (``pip install
cadpipe[bench]``); a missing one is skipped with a note.

Run: .venv/bin/python benchmarks/bench_collision.py [--configs N] [--repeat R]
     [--only panda|arm|pipes]
"""

import argparse
from pathlib import Path as FilePath

import fcl
import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from cadpipe import CollisionWorld, Mesh, Path, Pipe
from cadpipe.collision import Box, Joint, Robot
from cadpipe.collision.bodies import as_body

from _common import FclLoop, fcl_object, interleaved, obstacle_mesh, pipe_scene


def arm():
    """Seven capsule links (0.3 m, radius 4 cm) on alternating revolute joints."""
    link = Mesh.from_trimesh(trimesh.creation.capsule(height=0.3, radius=0.04, count=[12, 12]))
    link = link.transformed(trimesh.transformations.translation_matrix([0, 0, 0.15]))
    up = np.eye(4)
    up[2, 3] = 0.3
    joints, parent = [], "base"
    for k in range(7):
        axis = np.array([0.0, 0.0, 1.0]) if k % 2 == 0 else np.array([0.0, 1.0, 0.0])
        joints.append(Joint(f"j{k}", "revolute", parent, f"link{k}", up if k else np.eye(4),
                            axis, -2.6, 2.6))
        parent = f"link{k}"
    return Robot("arm", joints, {f"link{k}": link for k in range(7)})


def cell():
    """The workpiece (a 20,000-triangle torus) and three safety pipes around it."""
    work = Mesh.from_trimesh(trimesh.creation.torus(0.35, 0.12, major_sections=100,
                                                    minor_sections=100))
    place = np.eye(4)
    place[:3, 3] = (0.6, 0.0, 0.5)
    pipes = [Pipe(Path.spline(points, step=0.02), 0.03, sides=24, caps="round") for points in (
        [[0.2, -0.6, 0.2], [0.5, -0.4, 0.9], [0.9, -0.2, 1.0], [1.1, 0.3, 0.6]],
        [[-0.5, 0.5, 0.1], [0.0, 0.6, 0.6], [0.5, 0.7, 1.1], [0.9, 0.5, 1.3]],
        [[0.3, 0.4, 0.0], [0.7, 0.3, 0.2], [1.0, -0.1, 0.3], [1.0, -0.6, 0.5]])]
    return work, place, pipes


def pairs_of(report):
    return {frozenset((a, b)): d.decided_by for a, b, d in report.collisions}


def robot_cell(configs, repeat):
    robot = arm()
    work, place, pipes = cell()
    world = CollisionWorld()
    world.add_robot(robot)
    world.add("workpiece", work, transform=place)
    for k, p in enumerate(pipes):
        world.add(f"pipe{k}", p)
    manager = trimesh.collision.CollisionManager()
    for link, pose in robot.link_poses(None).items():
        manager.add_object(link, robot.link_meshes[link].to_trimesh(), transform=pose)
    manager.add_object("workpiece", work.to_trimesh(), transform=place)
    for k, p in enumerate(pipes):
        manager.add_object(f"pipe{k}", p.mesh().to_trimesh())
    allowed = {frozenset((a, b)) for a, b, _ in world.allowed}
    qs = np.random.default_rng(0).uniform(-2.6, 2.6, (configs, 7))
    links = list(robot.link_meshes)
    world.check()                      # build BVHs and bounds before timing, as trimesh did

    def ours_per_call():
        out = []
        for q in qs:
            world.set_joints("arm", q)
            out.append(pairs_of(world.check()))
        return out

    def theirs(poses_of):
        out = []
        for poses in poses_of():
            for link, pose in zip(links, poses):
                manager.set_transform(link, pose)
            _, names = manager.in_collision_internal(return_names=True)
            out.append({frozenset(n) for n in names} - allowed)
        return out

    seconds, results = interleaved({
        "cadpipe per call": ours_per_call,
        "trimesh per call": lambda: theirs(lambda: (robot.link_pose_array(q)[0] for q in qs)),
        "cadpipe batched": lambda: world.check_path("arm", qs),
        "trimesh batched": lambda: theirs(lambda: robot.link_pose_array(qs))}, repeat)
    per_call, batch, answers = (results[k] for k in ("cadpipe per call", "cadpipe batched",
                                                     "trimesh per call"))
    same_batch = sum(pairs_of(batch[c]) == per_call[c] for c in range(configs))
    contained = sum(1 for o in per_call for v in o.values() if v == "containment")
    same = sum(1 for o, t in zip(per_call, answers)
               if {k for k, v in o.items() if v != "containment"} == t)
    print(f"robot cell: 7 links, {len(work.faces)}-triangle workpiece, 3 safety pipes, "
          f"{configs} configurations (medians of {repeat} interleaved runs)")
    for kind in ("per call", "batched"):
        ours, theirs_s = seconds[f"cadpipe {kind}"], seconds[f"trimesh {kind}"]
        print(f"  {kind:9s} cadpipe {configs / ours:9.0f} configs/s   trimesh's manager "
              f"{configs / theirs_s:9.0f} configs/s   ratio {theirs_s / ours:5.2f}x")
    print(f"  check_path == check() loop: {same_batch}/{configs} configurations; same colliding "
          f"pairs as trimesh (containment aside): {same}/{configs}; containments only cadpipe "
          f"saw: {contained}")


def pipe_pair(poses, repeat):
    """Two safety pipes, and a pipe against a mesh, at random relative poses: one pose
    at a time (``set_pose`` + ``check(first_hit=True)``, ``distance``) and batched
    (``check_many``, the chains' own batched gaps), against FCL on the meshed pipes."""
    a, b, block = pipe_scene()
    chain_a, chain_b = as_body(a, "a").chain, as_body(b, "b").chain
    world = CollisionWorld()
    world.add("a", a)
    world.add("b", b)
    mixed = CollisionWorld()
    mixed.add("mesh", block)
    mixed.add("b", b)
    objects = [fcl_object(p.mesh()) for p in (a, b)]
    mesh_object = fcl_object(block)
    rng = np.random.default_rng(1)
    moves = np.tile(np.eye(4), (poses, 1, 1))
    moves[:, :3, :3] = Rotation.random(poses, random_state=rng).as_matrix()
    moves[:, :3, 3] = rng.uniform(-0.8, 0.8, (poses, 3))
    count = poses // 10
    print(f"pipe vs pipe: {len(a.path) - 1} and {len(b.path) - 1} units; meshes of "
          f"{len(a.mesh().faces)} and {len(b.mesh().faces)} triangles; pipe vs a "
          f"{len(block.faces)}-triangle torus; {poses} poses, distance on {count} "
          f"(medians of {repeat} interleaved runs)")

    def fcl_loop(first, query, n):
        def run():
            out = []
            for m in moves[:n]:
                objects[1].setTransform(fcl.Transform(m[:3, :3], m[:3, 3]))
                out.append(query(first, objects[1]))
            return np.array(out)
        return run

    def per_pose(w, n, query):
        def run():
            out = []
            for m in moves[:n]:
                w.set_pose("b", m)
                out.append(query(w))
            return np.array(out)
        return run

    request, distance = fcl.CollisionRequest(), fcl.DistanceRequest()

    def hit(x, y):
        return fcl.collide(x, y, request, fcl.CollisionResult()) > 0

    def apart(x, y):
        return fcl.distance(x, y, distance, fcl.DistanceResult())

    seconds, out = interleaved({
        "pipe-pipe collide: FCL meshes": fcl_loop(objects[0], hit, poses),
        "pipe-pipe collide: cadpipe per pose": per_pose(world, poses,
                                                        lambda w: bool(w.check(first_hit=True))),
        "pipe-pipe collide: cadpipe check_many": lambda: world.check_many({"b": moves}).colliding,
        "pipe-pipe collide: cadpipe chain gaps, batched":
            lambda: chain_a.gaps(chain_b, moves, stop_below=0.0)[0] <= 0,
        "pipe-mesh collide: FCL meshes": fcl_loop(mesh_object, hit, poses),
        "pipe-mesh collide: cadpipe per pose": per_pose(mixed, poses,
                                                        lambda w: bool(w.check(first_hit=True))),
        "pipe-mesh collide: cadpipe check_many": lambda: mixed.check_many({"b": moves}).colliding,
        "pipe-pipe distance: FCL meshes": fcl_loop(objects[0], apart, count),
        "pipe-pipe distance: cadpipe per pose": per_pose(
            world, count, lambda w: w.distance("a", "b").distance),
        "pipe-pipe distance: cadpipe chain gaps, batched":
            lambda: chain_a.gaps(chain_b, moves[:count])[0],
        "pipe-mesh distance: FCL meshes": fcl_loop(mesh_object, apart, count),
        "pipe-mesh distance: cadpipe per pose": per_pose(
            mixed, count, lambda w: w.distance("mesh", "b").distance),
    }, repeat)
    for label, s in seconds.items():
        query = label.split(":")[0]
        reference = seconds[f"{query}: FCL meshes"]
        n = count if "distance" in label else poses
        print(f"  {label:50s} {n / s:10.0f}/s   ratio to FCL {reference / s:7.2f}x")
    for query in ("pipe-pipe collide", "pipe-mesh collide"):
        mine = out[f"{query}: cadpipe per pose"]
        print(f"  {query}: check_many == per pose "
              f"{int((out[f'{query}: cadpipe check_many'] == mine).sum())}/{poses}; agree with "
              f"FCL on the meshes {int((out[f'{query}: FCL meshes'] == mine).sum())}/{poses}")


# -- the Panda cell: one state at a time against MuJoCo, pybullet, coal and FCL ------------
PANDA = FilePath(__file__).resolve().parents[1] / "assets" / "robots" / "panda"


def shifted(x, y, z):
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def panda_cell():
    """The Panda (SRDF: 35 allowed pairs with the adjacent links) and 4 obstacles: a
    table, a post, a workpiece (an 800-triangle torus) and a cable duct (a pipe)."""
    robot = Robot.from_urdf(PANDA / "panda.urdf", srdf=PANDA / "panda.srdf")
    lower = np.array([j.lower for j in robot.joints if j.name in robot.actuated])
    upper = np.array([j.upper for j in robot.joints if j.name in robot.actuated])
    obstacles = {
        "table": (Box((1.4, 1.4, 0.04)), shifted(0.3, 0.0, -0.05)),
        "post": (Box((0.1, 0.1, 1.2)), shifted(-0.35, -0.45, 0.6)),
        "workpiece": (Mesh.from_trimesh(trimesh.creation.torus(0.18, 0.05, major_sections=40,
                                                               minor_sections=10)),
                      shifted(0.55, 0.1, 0.35)),
        "duct": (Pipe(Path.spline([[-0.4, 0.55, 0.05], [0.1, 0.5, 0.7], [0.6, 0.35, 0.95]],
                                  step=0.05), 0.04, caps="round"), np.eye(4)),
    }
    return robot, lower, upper, obstacles


class CoalLoop(FclLoop):
    """The same loop through coal (hpp-fcl's successor)."""

    def __init__(self, robot, obstacles, allowed):
        import coal

        self.coal, self.robot, self.links = coal, robot, list(robot.link_meshes)

        def model(mesh):
            m = coal.BVHModelOBBRSS()
            m.beginModel(len(mesh.faces), len(mesh.vertices))
            m.addVertices(np.asarray(mesh.vertices, np.float64))
            m.addTriangles(np.asarray(mesh.faces, np.int64))
            m.endModel()
            return m

        self.models = {n: model(m) for n, m in robot.link_meshes.items()}
        self.poses = {}
        for name, (obj, pose) in obstacles.items():
            self.models[name] = model(obstacle_mesh(obj))
            self.poses[name] = coal.Transform3s(pose[:3, :3], pose[:3, 3])
        names = self.links + list(obstacles)
        self.pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1:]
                      if frozenset((a, b)) not in allowed
                      and (a in robot.link_meshes or b in robot.link_meshes)]
        self.request = coal.CollisionRequest()

    def __call__(self, q):
        coal, poses = self.coal, self.poses
        for link, pose in zip(self.links, self.robot.link_pose_array(q)[0]):
            poses[link] = coal.Transform3s(pose[:3, :3], pose[:3, 3])
        for a, b in self.pairs:
            result = coal.CollisionResult()
            if coal.collide(self.models[a], poses[a], self.models[b], poses[b], self.request,
                            result):
                return True
        return False


class Bullet:
    """pybullet: the URDF with self-collision, the allowed pairs filtered out, the
    obstacles as static shapes (concave triangle meshes); per state reset the
    joints, run collision detection, look for a contact at distance <= 0."""

    def __init__(self, robot, obstacles, allowed):
        import pybullet as pb

        self.pb = pb
        self.client = pb.connect(pb.DIRECT)
        self.body = pb.loadURDF(str(PANDA / "panda.urdf"), useFixedBase=True,
                                flags=pb.URDF_USE_SELF_COLLISION, physicsClientId=self.client)
        index = {pb.getBodyInfo(self.body, physicsClientId=self.client)[0].decode(): -1}
        joints = {}
        for j in range(pb.getNumJoints(self.body, physicsClientId=self.client)):
            info = pb.getJointInfo(self.body, j, physicsClientId=self.client)
            index[info[12].decode()] = j
            joints[info[1].decode()] = j
        for a, b in (tuple(p) for p in allowed):
            if a in index and b in index:
                pb.setCollisionFilterPair(self.body, self.body, index[a], index[b], 0,
                                          physicsClientId=self.client)
        self.joints = [joints[n] for n in robot.actuated]
        self.mimic = joints["panda_finger_joint2"], robot.actuated.index("panda_finger_joint1")
        for obj, pose in obstacles.values():
            mesh = obstacle_mesh(obj)
            shape = pb.createCollisionShape(
                pb.GEOM_MESH, vertices=np.asarray(mesh.vertices).tolist(),
                indices=np.asarray(mesh.faces).ravel().tolist(),
                flags=pb.GEOM_FORCE_CONCAVE_TRIMESH, physicsClientId=self.client)
            quat = Rotation.from_matrix(pose[:3, :3]).as_quat()
            pb.createMultiBody(0, shape, basePosition=pose[:3, 3].tolist(),
                               baseOrientation=quat.tolist(), physicsClientId=self.client)

    def __call__(self, q):
        pb, client = self.pb, self.client
        for j, v in zip(self.joints, q):
            pb.resetJointState(self.body, j, v, physicsClientId=client)
        pb.resetJointState(self.body, self.mimic[0], q[self.mimic[1]], physicsClientId=client)
        pb.performCollisionDetection(physicsClientId=client)
        return any(c[8] <= 0 for c in pb.getContactPoints(physicsClientId=client))


class Mujoco:
    """MuJoCo: the URDF compiled by MuJoCo (its meshes as convex hulls, as MuJoCo
    collides meshes), the allowed pairs excluded, the obstacles as world geoms (the
    duct as its capsules, the torus as its mesh's hull); per state
    ``mj_kinematics`` + ``mj_collision`` and a contact at distance <= 0."""

    def __init__(self, robot, obstacles, allowed):
        import mujoco

        self.mujoco = mujoco
        text = (PANDA / "panda.urdf").read_text()
        text = text.replace("<link", f'<mujoco><compiler meshdir="{PANDA / "meshes"}" '
                            'discardvisual="true" fusestatic="false"/></mujoco><link', 1)
        text = text.replace('filename="meshes/', 'filename="')
        spec = mujoco.MjSpec.from_string(text)
        links = set(robot.link_meshes)
        for a, b in (tuple(p) for p in allowed):
            if a in links and b in links:
                spec.add_exclude(bodyname1=a, bodyname2=b)
        for name, (obj, pose) in obstacles.items():
            quat = Rotation.from_matrix(pose[:3, :3]).as_quat()[[3, 0, 1, 2]]
            if isinstance(obj, Box):
                spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX,
                                        size=0.5 * np.array(obj.size), pos=pose[:3, 3],
                                        quat=quat)
            elif isinstance(obj, Pipe):
                chain = as_body(obj, name).chain
                for a, b, r in zip(chain.starts, chain.ends, chain.start_radii):
                    if np.linalg.norm(b - a) < 1e-9:     # a ball: MuJoCo 4 refuses the capsule
                        spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=a,
                                                size=[r, 0, 0])
                        continue
                    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                                            fromto=np.r_[a, b], size=[r, 0, 0])
            else:
                spec.add_mesh(name=name, uservert=np.asarray(obj.vertices).ravel(),
                              userface=np.asarray(obj.faces).ravel())
                spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name,
                                        pos=pose[:3, 3], quat=quat)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        names = [self.model.joint(j).name for j in range(self.model.njnt)]
        self.address = [self.model.jnt_qposadr[names.index(n)] for n in robot.actuated]
        self.mimic = self.model.jnt_qposadr[names.index("panda_finger_joint2")], \
            robot.actuated.index("panda_finger_joint1")

    def __call__(self, q):
        mujoco, data = self.mujoco, self.data
        data.qpos[self.address] = q
        data.qpos[self.mimic[0]] = q[self.mimic[1]]
        mujoco.mj_kinematics(self.model, data)
        mujoco.mj_collision(self.model, data)
        return bool(data.ncon) and bool((data.contact.dist[:data.ncon] <= 0).any())


def panda(configs, repeat):
    robot, lower, upper, obstacles = panda_cell()
    world = CollisionWorld()
    world.add_robot(robot, 0.5 * (lower + upper))
    for name, (obj, pose) in obstacles.items():
        world.add(name, obj, transform=pose)
    allowed = {frozenset((a, b)) for a, b, _ in world.allowed}
    qs = np.random.default_rng(0).uniform(lower, upper, (configs, len(lower)))
    peers = {"python-fcl loop, early exit": FclLoop}
    for label, make in (("coal loop, early exit", CoalLoop), ("pybullet", Bullet),
                        ("MuJoCo", Mujoco)):
        try:
            peers[label] = make(robot, obstacles, allowed)
        except ImportError as exc:
            print(f"  ({label} skipped: {exc}; pip install cadpipe[bench])")
    peers["python-fcl loop, early exit"] = FclLoop(robot, obstacles, allowed)

    def state_by_state(check):
        def run():
            out = np.empty(len(qs), bool)
            for c, q in enumerate(qs):
                out[c] = check(q)
            return out
        return run

    def ours(**options):
        def check(q):
            world.set_joints("panda", q)
            return bool(world.check(**options))
        return check

    runs = {"cadpipe set_joints + check(first_hit=True)": state_by_state(ours(first_hit=True)),
            "cadpipe ... check(first_hit=True, only=robot)":
                state_by_state(ours(first_hit=True, only="panda")),
            "cadpipe set_joints + check()": state_by_state(ours())}
    runs.update({label: state_by_state(peer) for label, peer in peers.items()})
    runs["cadpipe check_path (batched)"] = lambda: world.check_path("panda", qs).colliding
    seconds, verdicts = interleaved(runs, repeat)
    reference = verdicts["cadpipe set_joints + check()"]
    print(f"Panda cell: {len(robot.link_meshes)} links, {len(obstacles)} obstacles, "
          f"{len(allowed)} allowed pairs, {configs} random configurations "
          f"({int(reference.sum())} colliding); medians of {repeat} interleaved runs")
    base = seconds["pybullet"] if "pybullet" in seconds else None
    loop = seconds["python-fcl loop, early exit"]
    for label, s in seconds.items():
        ratio = f"   {base / s:5.2f}x pybullet's rate" if base else ""
        agree = int((verdicts[label] == reference).sum())
        print(f"  {label:46s} {configs / s:9.0f} states/s   {loop / s:5.2f}x the FCL loop"
              f"{ratio}   same verdict {agree}/{configs}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--configs", type=int, default=10_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--only", choices=("panda", "arm", "pipes"))
    args = parser.parse_args()
    parts = {"panda": panda, "arm": robot_cell, "pipes": pipe_pair}
    for name, part in parts.items():
        if args.only in (None, name):
            part(args.configs, args.repeat)

if __name__ == "__main__":
    main()
