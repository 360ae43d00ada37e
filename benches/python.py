"""The Python package's numbers in BENCH.md, each against its reference in one run:

    python benches/python.py read  [--n 64000]               # reading the state of N bodies
    python benches/python.py step  [--n 16000] [--threads 2]  # step() against `rigid bench`, interleaved
    python benches/python.py sweep [--points 100]             # Ray against the local backend

Run it with the venv of python/test.sh (target/python-venv/bin/python) from the repository root.
"""

import argparse
import json
import os
import re
import statistics
import subprocess
import time
from pathlib import Path

import rigid_sandbox as rs

ROOT = Path(__file__).resolve().parents[1]
RIGID = ROOT / "target" / "release" / "rigid"


def bench_read(a):
    sim = rs.Sim.bench("box-gas", n=a.n)
    sim.step(1)
    times = []
    for _ in range(a.repeats):
        start = time.perf_counter()
        state = (sim.positions, sim.orientations, sim.velocities, sim.angular_velocities)
        times.append(time.perf_counter() - start)
    rows = sum(len(x) for x in state)
    ms = [t * 1e3 for t in times]
    print(f"box-gas {a.n}: {len(sim)} bodies, 4 arrays ({rows} rows) read {a.repeats} times: "
          f"median {statistics.median(ms):.3f} ms, min {min(ms):.3f} ms, max {max(ms):.3f} ms")
    start = time.perf_counter()
    sim.state()
    print(f"for scale, sim.state() (the --out document as a dict): {(time.perf_counter() - start) * 1e3:.1f} ms")


def cli_bench_ms(a):
    """`rigid bench`'s median time of the schedule per step."""
    args = [RIGID, "bench", "box-gas", "--actors", a.n, "--threads", a.threads, "--steps", a.steps,
            "--warmup", a.warmup, "--json"]
    done = subprocess.run(list(map(str, args)), capture_output=True, text=True, check=True)
    return json.loads(done.stdout.splitlines()[-1])["median_ms_per_step"]


def cli_run_ms(a):
    """`rigid run`'s wall time of its stepping loop, per step, on scenes/box-gas.ron of N cubes."""
    args = [RIGID, "run", ROOT / "scenes" / "box-gas.ron", "--set", f"spawners[0].actors={a.n}",
            "--threads", a.threads, "--steps", a.steps]
    done = subprocess.run(list(map(str, args)), capture_output=True, text=True, check=True)
    wall = float(re.search(r"wall time ([0-9.]+) s", done.stdout).group(1))
    return wall / a.steps * 1e3


def python_ms(a):
    """Python: the median of single step() calls after the warm-up (as `rigid bench` times),
    and one step(N) call on the scene file, per step (as `rigid run` times)."""
    sim = rs.Sim.bench("box-gas", n=a.n, threads=a.threads)
    sim.step(a.warmup)
    times = []
    for _ in range(a.steps):
        start = time.perf_counter()
        sim.step()
        times.append(time.perf_counter() - start)
    sim = rs.Sim.from_file(ROOT / "scenes" / "box-gas.ron", set={"spawners[0].actors": a.n}, threads=a.threads)
    start = time.perf_counter()
    sim.step(a.steps)
    return statistics.median(times) * 1e3, (time.perf_counter() - start) / a.steps * 1e3


def bench_step(a):
    rows = []
    for k in range(a.rounds):
        # Interleaved, so a change in the machine's load falls on both alike.
        bench, run = cli_bench_ms(a), cli_run_ms(a)
        one, many = python_ms(a)
        rows.append((bench, one, run, many))
        print(f"round {k + 1}: rigid bench median {bench:.3f} ms/step, Python step() median {one:.3f}; "
              f"rigid run {run:.3f} ms/step, Python step({a.steps}) {many:.3f}")
    bench, one, run, many = (statistics.median(col) for col in zip(*rows))
    print(f"box-gas {a.n}, {a.threads} threads, medians of {a.rounds} rounds of {a.steps} steps: "
          f"single steps: rigid bench {bench:.3f} ms, Python step() {one:.3f} ms, ratio {one / bench:.4f}; "
          f"runs: rigid run {run:.3f} ms, Python step({a.steps}) {many:.3f} ms, ratio {many / run:.4f}")


def bench_sweep(a):
    import ray

    seeds = max(1, a.points // 10)
    grid = {"spawners[1].actor.restitution": [round(0.1 * k, 1) for k in range(10)],
            "spawners[1].seed": list(range(1, seeds + 1))}
    scene = ROOT / "scenes" / "spawners.ron"
    start = time.perf_counter()
    rs.run(scene, steps=a.steps, threads=1)
    print(f"one point: {a.steps} steps of {scene.name} on one thread: {time.perf_counter() - start:.3f} s")
    start = time.perf_counter()
    ray.init(num_cpus=a.cpus, include_dashboard=False, log_to_driver=False)
    t_init = time.perf_counter() - start

    def timed(backend):
        start = time.perf_counter()
        result = rs.sweep(scene, grid, steps=a.steps, backend=backend, threads=a.cpus)
        return time.perf_counter() - start, result

    cold, reference = timed("ray")  # starts the workers
    local, on_ray = [], []
    for k in range(a.rounds):
        # Interleaved: the machine's load moves by 2x within a minute here.
        t, result = timed("local")
        local.append(t)
        assert result == reference, "local and Ray results differ"
        t, result = timed("ray")
        on_ray.append(t)
        assert result == reference, "Ray results differ between sweeps"
        print(f"round {k + 1}: local {local[-1]:.2f} s, Ray {on_ray[-1]:.2f} s")
    ray.shutdown()
    lo, ra = statistics.median(local), statistics.median(on_ray)
    print(f"{len(reference)} points of {a.steps} steps, {a.cpus} CPUs, medians of {a.rounds} rounds: local {lo:.2f} s, "
          f"Ray {ra:.2f} s, ratio {ra / lo:.3f}; ray.init {t_init:.2f} s, first Ray sweep (starting the workers) "
          f"{cold:.2f} s; results identical")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="what", required=True)
    r = sub.add_parser("read")
    r.add_argument("--n", type=int, default=64000)
    r.add_argument("--repeats", type=int, default=50)
    s = sub.add_parser("step")
    s.add_argument("--n", type=int, default=16000)
    s.add_argument("--threads", type=int, default=os.cpu_count())
    s.add_argument("--steps", type=int, default=200)
    s.add_argument("--warmup", type=int, default=20)
    s.add_argument("--rounds", type=int, default=5)
    w = sub.add_parser("sweep")
    w.add_argument("--points", type=int, default=100)
    w.add_argument("--steps", type=int, default=300)
    w.add_argument("--cpus", type=int, default=os.cpu_count())
    w.add_argument("--rounds", type=int, default=3)
    a = p.parse_args()
    {"read": bench_read, "step": bench_step, "sweep": bench_sweep}[a.what](a)


if __name__ == "__main__":
    main()
