"""Batches on a Dask cluster give what the serial run gives, survive failing jobs and dead
workers, skip what is complete, and check trajectories against an FCL oracle.

One LocalCluster of two worker processes serves the whole module (it takes seconds to start).
"""

import html
import json
import os
import signal
import zipfile

import numpy as np
import pytest
import trimesh

from cadpipe.batch import read_jobs, run
from cadpipe.batch.params import csv_rows, fill, parameter_sets
from cadpipe.batch.work import densify
from cadpipe.cli import main
from cadpipe.collision.robot import Robot
from cadpipe.errors import CadpipeError, InputError

ARM = os.path.join(os.path.dirname(__file__), "..", "assets", "robots", "arm6", "arm6.urdf")
ARM = os.path.abspath(ARM)
#: the workpiece of the test cell: a box of this size centred here (metres)
WORK_SIZE, WORK_AT = (0.36, 0.5, 0.12), (0.56, 0.0, 0.06)
#: arm up and clear of the workpiece; the demo's pose, torch into the workpiece
UP = np.array([0.0, 0.2, 0.6, 0.0, 0.4, 0.0])
DOWN = np.array([0.0, 0.95, 1.25, 0.0, 0.9, 0.0])

CELL = f"""
name = "cell"
[robot]
urdf = "{ARM}"
joints = [0.0, 0.2, 0.6, 0.0, 0.4, 0.0]
[[parts]]
name = "workpiece"
kind = "box"
size = {list(WORK_SIZE)}
transform = {{ translate = {list(WORK_AT)} }}
"""

PART = """
name = "duct"
units = "mm"
[[parts]]
kind = "pipe"
radius = "${radius}"
sides = "${sides}"
caps = "round"
path = [[0, 0, 0], [40, 0, 0], [40, 30, 20]]
"""


def write_trajectory(path, q, header="time,j1,j2,j3,j4,j5,j6", dt=0.1):
    np.savetxt(path, np.c_[np.arange(len(q)) * dt, q], delimiter=",", header=header,
               comments="")


@pytest.fixture(scope="module")
def cluster():
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as local, Client(local) as client:
        yield local, client


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    """A folder with the cell, a part template, trajectories and a JOBS file."""
    folder = tmp_path_factory.mktemp("batch")
    (folder / "cell.toml").write_text(CELL)
    (folder / "duct.toml").write_text(PART)
    (folder / "traj").mkdir()
    s = np.linspace(0, 1, 12)[:, None]
    write_trajectory(folder / "traj" / "hit.csv", UP + s * (DOWN - UP))
    write_trajectory(folder / "traj" / "clear.csv",
                     UP + s * np.array([1.2, -0.1, 0.1, 0.5, 0.0, 1.0]))
    (folder / "bad.csv").write_text("j1,j2\n0,5.0\n0,0\n")          # j2 beyond its limit
    (folder / "rows.csv").write_text("radius,sides\n4,8\n5,12\n")
    (folder / "jobs.toml").write_text("""
[[jobs]]
name = "duct-r${radius}-n${sides}"
spec = "duct.toml"
grid = { radius = [3, 6], sides = [8, 16] }
outputs = ["duct.stl"]

[[jobs]]
spec = "duct.toml"
rows = "rows.csv"
outputs = ["duct.stl", "duct.3mf"]

[[jobs]]
name = "broken"
spec = "duct.toml"
params = { radius = -1, sides = 8 }
outputs = ["duct.stl"]

[[jobs]]
cell = "cell.toml"
trajectories = "traj/*.csv"
tool = "tool"
pipe = { radius = 0.03, sides = 12 }

[[jobs]]
name = "limits"
cell = "cell.toml"
trajectory = "bad.csv"
""")
    return folder


def contents(path):
    """A file's bytes; a 3MF archive's members' bytes (the zip stamps the time of writing)."""
    if path.suffix == ".3mf":
        with zipfile.ZipFile(path) as archive:
            return {name: archive.read(name) for name in archive.namelist()}
    return path.read_bytes()


def without_run(record):
    return {k: v for k, v in record.items() if k != "run"}


@pytest.fixture(scope="module")
def serial(cell, tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    return out, run(cell / "jobs.toml", out, workers=0)


@pytest.fixture(scope="module")
def parallel(cell, cluster, tmp_path_factory):
    out = tmp_path_factory.mktemp("parallel")
    return out, run(cell / "jobs.toml", out, scheduler=cluster[0].scheduler_address)


def test_cluster_run_equals_serial_run(serial, parallel):
    (out_a, a), (out_b, b) = serial, parallel
    names = [r["name"] for r in a.jobs]
    assert names == ["duct-r3-n8", "duct-r3-n16", "duct-r6-n8", "duct-r6-n16", "duct-1",
                     "duct-2", "broken", "clear", "hit", "limits"]
    assert [without_run(r) for r in a.jobs] == [without_run(r) for r in b.jobs]
    workers = {r["run"]["worker"] for r in b.jobs if r["run"]}
    assert len(workers) == 2                          # both processes did work
    for record in a.jobs:
        for name in record["files"]:
            assert contents(out_a / record["name"] / name) == \
                contents(out_b / record["name"] / name), (record["name"], name)
    summary = json.loads((out_b / "summary.json").read_text())
    assert [without_run(r) for r in summary["jobs"]] == [without_run(r) for r in a.jobs]
    assert summary["counts"] == {"ok": 8, "failed": 2, "not run": 0, "reused": 0}


def test_failing_jobs_are_recorded_and_the_others_run(parallel):
    out, summary = parallel
    by_name = {r["name"]: r for r in summary.jobs}
    broken, limits = by_name["broken"], by_name["limits"]
    assert broken["status"] == limits["status"] == "failed"
    assert "radius" in broken["error"] and "\n" not in broken["error"]
    assert "j2" in limits["error"] and "limits" in limits["error"]
    assert not (out / "broken" / "duct.stl").exists()
    page = (out / "summary.html").read_text()
    assert html.escape(broken["error"].split(": ")[-1]) in page
    ok = [r for r in summary.jobs if r["status"] == "ok"]
    assert len(ok) == 8 and all(r["files"] for r in ok)


def test_built_parts_are_the_parameters_solids(parallel):
    out, summary = parallel
    by_name = {r["name"]: r for r in summary.jobs}
    for radius, sides in ((3, 8), (6, 16)):
        record = by_name[f"duct-r{radius}-n{sides}"]
        assert record["params"] == {"radius": radius, "sides": sides}
        mesh = trimesh.load(out / record["name"] / "duct.stl")
        assert mesh.is_watertight
        # a 3-segment tube with round caps: volume grows as the radius squared
        assert mesh.volume == pytest.approx(record["solid"]["volume"], rel=1e-5)
    small, large = (by_name[n]["solid"]["volume"] for n in ("duct-r3-n8", "duct-r6-n8"))
    assert 3.0 < large / small < 4.5
    assert by_name["duct-2"]["params"] == {"radius": 5, "sides": 12}


class Oracle:
    """FCL through trimesh's collision managers: the robot's links and the workpiece."""

    def __init__(self, robot):
        self.robot, self.links = robot, trimesh.collision.CollisionManager()
        for link, mesh in robot.link_meshes.items():
            self.links.add_object(link, trimesh.Trimesh(mesh.vertices, mesh.faces))
        self.work = trimesh.collision.CollisionManager()
        box = trimesh.creation.box(WORK_SIZE)
        box.apply_translation(WORK_AT)
        self.work.add_object("workpiece", box)

    def at(self, q):
        for link, pose in self.robot.link_poses(q).items():
            self.links.set_transform(link, pose)
        return self

    def touching(self, q):
        return self.at(q).links.in_collision_other(self.work, return_names=True)

    def distance(self, q):
        return self.at(q).links.min_distance_other(self.work)


def along(q, waypoint):
    k = min(int(waypoint), len(q) - 2)
    return q[k] + (waypoint - k) * (q[k + 1] - q[k])


def test_trajectory_verdicts_match_an_fcl_oracle(parallel, cell):
    out, summary = parallel
    robot = Robot.from_urdf(ARM)
    by_name = {r["name"]: r for r in summary.jobs}
    hit, clear = by_name["hit"], by_name["clear"]
    q_hit = np.loadtxt(cell / "traj" / "hit.csv", delimiter=",", skiprows=1)[:, 1:]
    assert hit["verdict"] == "collision"
    first = hit["first_collision"]
    assert first["time"] == pytest.approx(first["waypoint"] * 0.1)
    fcl = Oracle(robot)
    touching, names = fcl.touching(along(q_hit, first["waypoint"]))
    assert touching and {a for a, _ in names} == {a for a, _ in first["pairs"]}
    dense, at = densify(q_hit, 0.01)
    assert not any(fcl.touching(config)[0] for config in dense[at < first["waypoint"]])

    q_clear = np.loadtxt(cell / "traj" / "clear.csv", delimiter=",", skiprows=1)[:, 1:]
    assert clear["verdict"] == "clear" and clear["first_collision"] is None
    dense, at = densify(q_clear, 0.01)
    distances = [fcl.distance(config) for config in dense]
    gap = clear["clearance"]
    assert gap["distance"] == pytest.approx(min(distances), abs=1e-6)
    assert gap["waypoint"] == pytest.approx(at[int(np.argmin(distances))])
    assert gap["b"] == "workpiece"
    report = json.loads((out / "clear" / "report.json").read_text())
    assert report["checked"] == len(dense) and report["verdict"] == "clear"


def test_the_safety_pipe_contains_the_tool_path(parallel, cell):
    out, _ = parallel
    q = np.loadtxt(cell / "traj" / "clear.csv", delimiter=",", skiprows=1)[:, 1:]
    robot = Robot.from_urdf(ARM)
    pipe = trimesh.load(out / "clear" / "safety_pipe.stl")
    pipe.apply_scale(1e-3)                         # STL is written in millimetres
    assert pipe.is_watertight and pipe.volume > 0
    # the whole motion of the tool point lies a radius inside the pipe's flats and caps
    t = np.linspace(0, 1, 4001)[:, None]
    dense = np.concatenate([a + t * (b - a) for a, b in zip(q[:-1], q[1:])])
    tips = robot.link_pose_array(dense)[:, list(robot.link_meshes).index("tool"), :3, 3]
    depth = trimesh.proximity.signed_distance(pipe, tips)
    assert depth.min() >= 0.03 - 1e-6


def test_a_killed_workers_job_completes_once(cell, cluster, tmp_path):
    local, client = cluster
    (tmp_path / "slow").mkdir()
    s = np.linspace(0, 1, 12)[:, None]
    for k in range(6):
        write_trajectory(tmp_path / "slow" / f"p{k}.csv",
                         UP + s * np.array([1.0 + 0.1 * k, -0.1, 0.1, 0.5, 0.0, 1.0]))
    jobs = [{"cell": str(cell / "cell.toml"), "trajectories": str(tmp_path / "slow" / "*.csv"),
             "step": 0.002}]
    pids = client.run(os.getpid)
    killed = []

    def kill_a_busy_worker(record, tally):
        if record is None or killed:
            return
        busy = [(address, keys) for address, keys in client.processing().items() if keys]
        if busy:
            address, keys = busy[0]
            os.kill(pids[address], signal.SIGKILL)
            killed.append((pids[address], [k.rsplit("-", 1)[1] for k in keys]))

    summary = run(jobs, tmp_path / "out", scheduler=local.scheduler_address,
                  progress=kill_a_busy_worker)
    assert killed, "no worker was busy to kill"
    pid, lost_jobs = killed[0]
    names = [r["name"] for r in summary.jobs]
    assert names == [f"p{k}" for k in range(6)]
    assert all(r["status"] == "ok" for r in summary.jobs), [r["error"] for r in summary.jobs]
    assert summary.counts["ok"] == 6
    redone = {r["name"]: r for r in summary.jobs}
    for name in lost_jobs:                    # the killed worker's jobs ran elsewhere
        assert not redone[name]["run"]["worker"].endswith(f":{pid}")
    for name in names:
        assert json.loads((tmp_path / "out" / name / "job.json").read_text())["name"] == name
    client.wait_for_workers(2)
    assert pid not in client.run(os.getpid).values()


def test_a_rerun_skips_complete_jobs_and_redoes_changed_ones(cell, cluster, tmp_path):
    address = cluster[0].scheduler_address
    jobs = [{"spec": str(cell / "duct.toml"), "name": "d${radius}",
             "grid": {"radius": [3, 4, 5]}, "params": {"sides": 8}, "outputs": ["d.stl"]}]
    first = run(jobs, tmp_path, scheduler=address)
    stamps = {r["name"]: (tmp_path / r["name"] / "d.stl").stat().st_mtime_ns for r in first.jobs}
    again = run(jobs, tmp_path, scheduler=address)
    assert again.counts == {"ok": 3, "failed": 0, "not run": 0, "reused": 3}
    assert [without_run(r) for r in again.jobs] == [without_run(r) for r in first.jobs]
    (tmp_path / "d4" / "d.stl").unlink()                      # an output gone
    jobs[0]["params"] = {"sides": 8}
    jobs[0]["grid"] = {"radius": [3, 4, 6]}                   # d6 is new, d5 is dropped
    third = run(jobs, tmp_path, scheduler=address)
    assert [r["name"] for r in third.jobs] == ["d3", "d4", "d6"]
    assert [bool(r["run"].get("reused")) for r in third.jobs] == [True, False, False]
    assert (tmp_path / "d3" / "d.stl").stat().st_mtime_ns == stamps["d3"]
    forced = run(jobs, tmp_path, workers=0, force=True)
    assert forced.counts["reused"] == 0


def test_ctrl_c_leaves_the_summary_of_what_finished(cell, cluster, tmp_path):
    jobs = [{"spec": str(cell / "duct.toml"), "name": "d${radius}",
             "grid": {"radius": [3, 4, 5, 6, 7, 8]}, "params": {"sides": 8},
             "outputs": ["d.stl"]}]

    def interrupt(record, tally):
        if record is not None:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run(jobs, tmp_path, scheduler=cluster[0].scheduler_address, progress=interrupt)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["interrupted"] is True
    statuses = [r["status"] for r in summary["jobs"]]
    assert statuses.count("ok") >= 1 and len(statuses) == 6
    assert set(statuses) <= {"ok", "not run"}
    resumed = run(jobs, tmp_path, scheduler=cluster[0].scheduler_address)
    assert resumed.counts["ok"] == 6 and resumed.counts["reused"] >= 1


def test_the_callers_limits_reach_the_workers(cell, cluster, tmp_path):
    from cadpipe import limits

    jobs = [{"spec": str(cell / "duct.toml"), "params": {"radius": 3, "sides": 8},
             "outputs": ["d.stl"]}]
    with limits.using(max_triangles=50):
        summary = run(jobs, tmp_path, scheduler=cluster[0].scheduler_address)
    assert summary.jobs[0]["status"] == "failed" and "max_triangles" in summary.jobs[0]["error"]


def test_cli_runs_a_batch_and_reports_failed_jobs(cell, cluster, tmp_path, capsys):
    code = main(["batch", str(cell / "jobs.toml"), "-o", str(tmp_path),
                 "--scheduler", cluster[0].scheduler_address])
    captured = capsys.readouterr()
    assert code == 3                                   # it ran; two jobs failed
    lines = [line for line in captured.err.splitlines() if line.startswith("[")]
    assert len(lines) == 10 and sum("FAILED" in line for line in lines) == 2
    assert "10 jobs: 8 ok (0 reused), 2 failed" in captured.out


@pytest.mark.parametrize("jobs, message", [
    ('[[jobs]]\nspec = "duct.toml"\ncolour = 1\n', "jobs[0].colour: unknown key"),
    ('[[jobs]]\nspec = "duct.toml"\nparams = { radius = 3 }\n', "${sides} but no value"),
    ('[[jobs]]\nspec = "duct.toml"\nparams = { radius = 3, sides = 8, wall = 1 }\n',
     "'wall' is not used"),
    ('[[jobs]]\nspec = "nope.toml"\n', "no such file"),
    ('[[jobs]]\ncell = "cell.toml"\n', "give trajectory"),
    ('[[jobs]]\nspec = "duct.toml"\ngrid = { radius = 3, sides = [8] }\n', "grid.radius"),
    ('[[jobs]]\nspec = "duct.toml"\nrows = "short.csv"\n', "line 3"),
    ('[[jobs]]\nname = "a b"\nspec = "duct.toml"\nparams = { radius = 3, sides = 8 }\n',
     "cannot name a folder"),
    ('[[jobs]]\nname = "summary.json"\nspec = "duct.toml"\nparams = { radius = 3, sides = 8 }\n',
     "the batch's own summary.json"),
    ('[[jobs]]\nname = "Summary.HTML"\nspec = "duct.toml"\nparams = { radius = 3, sides = 8 }\n',
     "the batch's own summary.html"),
    ('[[jobs]]\nname = "x"\nspec = "duct.toml"\nrows = "rows.csv"\n'
     '[[jobs]]\nname = "x-1"\nspec = "duct.toml"\nparams = { radius = 3, sides = 8 }\n',
     "also the name of a job"),
    ('[[jobs]]\ncell = "cell.toml"\ntrajectory = "words.csv"\n', "rows of numbers"),
    # globs stay in the JOBS file's folder: no walk of the whole disk
    ('[[jobs]]\ncell = "cell.toml"\ntrajectories = "/**/*.csv"\n',
     "jobs[0].trajectories: '/**/*.csv' reaches outside the JOBS file's folder"),
    ('[[jobs]]\ncell = "cell.toml"\ntrajectories = "../**/*.csv"\n',
     "reaches outside the JOBS file's folder"),
    ("jobs = 3", "expected a list"),
    # a million combinations: refused from the counts, before one is made
    ('[[jobs]]\nspec = "duct.toml"\ngrid = { radius = ' + str(list(range(1, 1001))) +
     ', sides = ' + str(list(range(3, 1003))) + ' }\n',
     "jobs[0].grid: a grid of 1000 x 1000 combinations needs about 1,000,000 jobs, more "
     "than the limit of 100,000"),
    ('max_jobs = 2\n[[jobs]]\nspec = "duct.toml"\ngrid = { radius = [3, 4, 5], sides = [8] }\n',
     "more than the limit of 2; raise it with"),
    ('max_jobs = 2\n[[jobs]]\nspec = "duct.toml"\ngrid = { radius = [3, 4], sides = [8] }\n'
     '[[jobs]]\nname = "one"\nspec = "duct.toml"\nparams = { radius = 3, sides = 8 }\n',
     "jobs[1]: jobs[0] to jobs[1] needs about 3 jobs"),
])
def test_cli_bad_input_is_one_line_and_runs_nothing(cell, tmp_path, capsys, jobs, message):
    (cell / "short.csv").write_text("radius,sides\n3,8\n4\n")
    (cell / "words.csv").write_text("j1,j2\n0,zero\n")
    file = cell / "bad_jobs.toml"
    file.write_text(jobs)
    code = main(["batch", str(file), "-o", str(tmp_path / "out"), "--workers", "0"])
    err = capsys.readouterr().err
    assert code == 1
    assert len(err.strip().splitlines()) == 1 and message in err, err
    assert not (tmp_path / "out").exists()


def test_without_dask_parallel_runs_say_how_to_install_it(cell, tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(InputError, match=r"cadpipe\[batch\]"):
        run(cell / "jobs.toml", tmp_path, workers=2)


def test_placeholders_keep_their_types_and_fill_text():
    template = {"radius": "${r}", "path": "${points}", "name": "duct-${r}-$${x}",
                "parts": [{"sides": "${n}"}], "${r}": "keys stay"}
    filled = fill(template, {"r": 0.5, "points": [[0, 0, 0], [1, 0, 0]], "n": 8})
    assert filled == {"radius": 0.5, "path": [[0, 0, 0], [1, 0, 0]], "name": "duct-0.5-${x}",
                      "parts": [{"sides": 8}], "${r}": "keys stay"}
    with pytest.raises(InputError, match="malformed placeholder"):
        fill({"a": "${1x}"}, {})
    with pytest.raises(InputError, match="must be a number or a string"):
        fill({"a": "x${p}"}, {"p": [1, 2]})


def test_grids_vary_the_last_key_fastest_and_rows_keep_types(tmp_path):
    sets = parameter_sets({"wall": 1}, grid={"r": [1, 2], "n": [8, 12, 16]})
    assert [(s["r"], s["n"]) for s in sets] == [(1, 8), (1, 12), (1, 16), (2, 8), (2, 12),
                                                (2, 16)]
    assert all(s["wall"] == 1 for s in sets)
    (tmp_path / "p.csv").write_text("# comment\nr,n,label,on\n0.5,8,a b,true\n1e-3,12,x,false\n")
    assert csv_rows(tmp_path / "p.csv") == [{"r": 0.5, "n": 8, "label": "a b", "on": True},
                                            {"r": 0.001, "n": 12, "label": "x", "on": False}]
    with pytest.raises(InputError, match="both params and grid"):
        parameter_sets({"r": 1}, grid={"r": [1]})


def test_job_hashes_follow_content(cell, tmp_path):
    jobs = read_jobs(cell / "jobs.toml")
    assert len({j.hash for j in jobs}) == len(jobs)
    again = read_jobs(cell / "jobs.toml")
    assert [j.hash for j in jobs] == [j.hash for j in again]
    moved = tmp_path / "hit.csv"
    moved.write_text((cell / "traj" / "hit.csv").read_text().replace("0.0000", "0.0001", 1))
    changed = read_jobs([{"cell": str(cell / "cell.toml"), "trajectory": str(moved)}])[0]
    original = next(j for j in jobs if j.name == "hit")
    assert changed.hash != original.hash
    with pytest.raises(CadpipeError):
        read_jobs([])


def test_between_certifies_the_motion_the_samples_miss(cell, tmp_path):
    """A base swing low over the workpiece, clear at both ends: checked at its waypoints
    only (``step`` wider than the swing) it is "clear"; with ``between`` the motion check
    finds the contact, at a configuration FCL sees within the tolerance and before which
    FCL sees none, and with a margin wider than the ends' clearance it is "too close"."""
    a, b = DOWN.copy(), DOWN.copy()
    a[0], b[0] = -0.8, 0.8
    write_trajectory(tmp_path / "swing.csv", np.array([a, b]))
    job = {"cell": str(cell / "cell.toml"), "trajectory": str(tmp_path / "swing.csv"),
           "step": 2.0, "pipe": {"radius": 0.03, "sides": 8}}
    summary = run([{**job, "name": "sampled"}, {**job, "name": "between", "between": True},
                   {**job, "name": "padded", "between": True, "margin": 0.25,
                    "trajectory": str(tmp_path / "swing.csv")}], tmp_path / "out", workers=0)
    by_name = {r["name"]: r for r in summary.jobs}
    assert by_name["sampled"]["verdict"] == "clear"
    found = by_name["between"]
    assert found["verdict"] == "collision"
    first = found["first_collision"]
    assert 0 < first["waypoint"] < 1 and first["pairs"][0][1] == "workpiece"
    fcl = Oracle(Robot.from_urdf(ARM))
    q = np.array([a, b])
    assert fcl.distance(along(q, first["waypoint"])) < 1e-4 + 1e-9
    earlier = q[0] + np.linspace(0, first["waypoint"], 2000, endpoint=False)[:, None] * (b - a)
    assert min(fcl.distance(config) for config in earlier) > 0
    report = json.loads((tmp_path / "out" / "between" / "report.json").read_text())
    assert report["motion"]["free"] is False and report["motion"]["tolerance"] == 1e-4
    assert [c["configurations"] for c in report["collisions"]] == [0]
    padded = by_name["padded"]
    assert padded["verdict"] == "too close" and padded["first_collision"] is None


@pytest.mark.parametrize("entry, key", [
    ({"margin": 0.1}, "margin"),                        # without between
    ({"between": True, "margin": -1}, "margin"),
    ({"between": True, "tolerance": 0}, "tolerance"),
    ({"between": "yes"}, "between"),
])
def test_motion_options_are_refused_up_front(cell, entry, key):
    with pytest.raises(CadpipeError) as caught:
        read_jobs([{"cell": str(cell / "cell.toml"),
                    "trajectory": str(cell / "traj" / "hit.csv"), **entry}])
    assert caught.value.key.endswith(key)


def test_a_build_job_refuses_motion_options(cell):
    with pytest.raises(CadpipeError, match="only a trajectory job") as caught:
        read_jobs([{"spec": str(cell / "duct.toml"), "params": {"radius": 3, "sides": 8},
                    "between": True}])
    assert caught.value.key.endswith("between")
