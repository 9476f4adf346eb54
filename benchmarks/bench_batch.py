"""cadpipe batch: 200 trajectory jobs on the demo's welding cell, serial vs a local Dask cluster.

    PYTHONPATH=$PWD .venv/bin/python benchmarks/bench_batch.py [--jobs 200] [--rounds 3]

The demo cell (``cadpipe.cli.welding_cell.build_cell``: the six-axis arm, the workpiece,
the coolant tee, the spliced safety pipe along the seam) is written as a cell spec whose
tee and pipe are STL parts. Each job checks one trajectory of 30 waypoints (every 0.01 rad
between them), measures the clearance, wraps the tool path in a safety pipe and writes it.
Serial (``workers=0``, in this process) and the cluster (one single-threaded process per
core, started once beforehand) take turns, A B A B, each after one untimed warm-up run;
medians are reported. Per-job overhead is the engine's extra worker-time per job,
``(cluster wall * workers - serial wall) / jobs``; the no-op round trip is Dask's own cost
per task. CPU seconds (this process, which hosts the scheduler, plus every worker) say what
the engine costs whatever the load: ``workers * serial CPU / cluster CPU`` is the speed-up
idle cores would allow. The load average is printed before and after: the machine is shared.
"""

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path as FilePath

import numpy as np

from cadpipe.batch import read_jobs, run
from cadpipe.cli.welding_cell import ARM, ARM_POSE, build_cell

#: arm lifted above the seam; programs sweep around it (radians)
LIFT = np.array([0.0, 0.75, 1.1, 0.0, 0.95, 0.0])


def write_cell(folder):
    """The demo cell as a spec in ``folder``; returns its path."""
    cell = build_cell()
    tee = next(p for p in cell.assembly.parts if p.name == "coolant_tee").obj
    tee.mesh().export(folder / "coolant_tee.stl")
    cell.safety.export(folder / "safety_pipe.stl")
    (folder / "cell.toml").write_text(f"""
name = "weld_cell"
[robot]
urdf = "{ARM}"
joints = {list(ARM_POSE)}
group = "arm6"
[[parts]]
name = "workpiece"
kind = "box"
size = [0.36, 0.5, 0.12]
transform = {{ translate = [0.56, 0.0, 0.06] }}
[[parts]]
name = "coolant_tee"
kind = "mesh"
file = "coolant_tee.stl"
[[parts]]
name = "safety_pipe"
kind = "mesh"
file = "safety_pipe.stl"
[[allow]]
a = "workpiece"
b = "safety_pipe"
[[allow]]
a = "tool"
b = "safety_pipe"
""")
    return folder / "cell.toml"


def write_programs(folder, count, seed=7):
    """``count`` trajectories of 30 waypoints: a sweep between two poses around LIFT."""
    rng = np.random.default_rng(seed)
    (folder / "programs").mkdir()
    s = np.linspace(0.0, 1.0, 30)[:, None]
    for k in range(count):
        a, b = LIFT + rng.uniform(-0.25, 0.25, 6), LIFT + rng.uniform(-0.25, 0.25, 6)
        q = a + s * (b - a) + 0.05 * np.sin(np.pi * s) * rng.uniform(-1, 1, 6)
        np.savetxt(folder / "programs" / f"p{k:03d}.csv", np.c_[s[:, 0] * 6.0, q],
                   delimiter=",", header="time,j1,j2,j3,j4,j5,j6", comments="")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--workers", type=int, default=os.cpu_count())
    args = parser.parse_args()

    from distributed import Client, LocalCluster

    with tempfile.TemporaryDirectory() as tmp:
        folder = FilePath(tmp)
        cell = write_cell(folder)
        write_programs(folder, args.jobs)
        jobs = read_jobs([{"cell": str(cell), "trajectories": str(folder / "programs/*.csv"),
                           "tool": "tool", "pipe": {"radius": 0.04, "sides": 12}}])
        load_before = os.getloadavg()
        began = time.perf_counter()
        cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
        startup = time.perf_counter() - began

        def serial():
            return run(jobs, folder / "serial", workers=0, force=True)

        def parallel():
            return run(jobs, folder / "cluster", scheduler=cluster.scheduler_address,
                       force=True)

        first = serial(), parallel()                      # warm-up: cells built, imports
        same = [{k: v for k, v in r.items() if k != "run"} for r in first[0].jobs] == \
            [{k: v for k, v in r.items() if k != "run"} for r in first[1].jobs]
        times = {"serial": [], "cluster": []}
        cpu = {"serial": [], "cluster": []}

        def cpu_seconds():
            """CPU seconds so far of this process (client and scheduler) and the workers."""
            return time.process_time() + sum(client.run(time.process_time).values())

        for _ in range(args.rounds):
            for name, call in (("serial", serial), ("cluster", parallel)):
                t, c = time.perf_counter(), cpu_seconds()
                summary = call()
                times[name].append(time.perf_counter() - t)
                cpu[name].append(cpu_seconds() - c)
                assert summary.counts["ok"] == args.jobs, summary.counts
        began = time.perf_counter()
        client.gather(client.map(abs, range(-args.jobs, 0), pure=False))
        noop = (time.perf_counter() - began) / args.jobs
        client.close()
        cluster.close()
        load_after = os.getloadavg()

    verdicts = [r["verdict"] for r in first[0].jobs]
    s, c = statistics.median(times["serial"]), statistics.median(times["cluster"])
    print(f"{args.jobs} trajectory jobs on the demo cell "
          f"({verdicts.count('collision')} collide, {verdicts.count('clear')} clear); "
          f"cluster results equal serial: {same}")
    print(f"load average before {load_before[0]:.2f}, after {load_after[0]:.2f} "
          f"({os.cpu_count()} cores)")
    print(f"cluster start ({args.workers} processes): {startup:.2f} s")
    print(f"serial:  median {s:.2f} s  ({1000 * s / args.jobs:.1f} ms/job)  "
          f"rounds {', '.join(f'{t:.2f}' for t in times['serial'])}")
    print(f"cluster: median {c:.2f} s  ({1000 * c / args.jobs:.1f} ms/job)  "
          f"rounds {', '.join(f'{t:.2f}' for t in times['cluster'])}")
    cs, cc = statistics.median(cpu["serial"]), statistics.median(cpu["cluster"])
    print(f"CPU time: serial {cs:.2f} s, cluster {cc:.2f} s (workers, client and scheduler): "
          f"{1000 * (cc - cs) / args.jobs:.1f} ms more per job; on {args.workers} idle cores "
          f"that bounds the speed-up by {args.workers * cs / cc:.2f}x")
    print(f"speed-up {s / c:.2f}x; engine overhead "
          f"{1000 * (c * args.workers - s) / args.jobs:.1f} ms of worker time per job; "
          f"Dask no-op round trip {1000 * noop:.2f} ms per task")


if __name__ == "__main__":
    main()
