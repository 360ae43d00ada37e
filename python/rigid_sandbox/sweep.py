"""Parameter sweeps: one scene, the cartesian product of a grid of `--set` overrides, one task
per grid point, on a Ray cluster or on this machine's cores. Each point steps on one thread;
results are the same bits whichever backend runs them, and come back in grid order."""

import itertools
import json
import os
from concurrent.futures import ThreadPoolExecutor

from . import _native

BACKENDS = ("ray", "local")


def grid_points(grid):
    """The grid's points in order, the first key varying slowest: a list of {PATH: value}."""
    if not isinstance(grid, dict):
        raise TypeError("grid must be a dict of PATH: [values]")
    keys = list(grid)
    columns = []
    for key in keys:
        values = grid[key]
        if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
            raise TypeError(f"grid[{key!r}] must be a list of values, got {values!r}")
        columns.append(list(values))
    return [dict(zip(keys, combo)) for combo in itertools.product(*columns)]


def sweep(scene, grid, steps=None, backend="ray", threads=None):
    """Runs the scene file `scene` once per point of `grid` ({PATH: [values]}, each PATH as
    `rigid run --set PATH=VALUE` takes it) for `steps` steps (default: the scene's own).

    backend="ray" runs one task per point on Ray: `ray.init()` joins the cluster RAY_ADDRESS
    names, else starts a local one, unless Ray is initialised already. backend="local" runs
    the points on `threads` threads of this process (default: the number of cores), the GIL
    released while each steps. Returns [{"set": point, "state": final state}] in grid order.
    Every point is checked before any runs: a bad one raises SceneError at once."""
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {', '.join(map(repr, BACKENDS))}, got {backend!r}")
    path = os.fspath(scene)
    points = grid_points(grid)
    text = _native.read_scene(path)
    for point in points:
        _native.check_scene(text, path, point)
    run = _run_on_ray if backend == "ray" else _run_here
    results = run(text, path, points, steps, threads)
    return [{"set": point, "state": json.loads(_unwrap(r))} for point, r in zip(points, results)]


def run_point(text, path, point, steps):
    """One grid point on one thread: ("ok", the state's JSON) or (error class, message), so a
    worker's error reaches the caller as the same exception with the same message."""
    try:
        return ("ok", _native.run_scene(path, set=point, steps=steps, threads=1, text=text))
    except (_native.SceneError, _native.SimulationError) as e:
        return (type(e).__name__, str(e))


def _unwrap(result):
    kind, payload = result
    if kind == "ok":
        return payload
    raise getattr(_native, kind)(payload)


def _run_here(text, path, points, steps, threads):
    workers = threads or os.cpu_count() or 1
    with ThreadPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(lambda p: run_point(text, path, p, steps), points))


def _run_on_ray(text, path, points, steps, threads):
    try:
        import ray
    except ImportError as e:
        raise ImportError("backend='ray' needs Ray: pip install 'rigid-sandbox[ray]'") from e
    if not ray.is_initialized():
        ray.init()  # joins RAY_ADDRESS if it is set, else starts a local cluster
    task = ray.remote(num_cpus=1)(run_point)
    shared = ray.put(text)  # one copy of the scene for all tasks
    return ray.get([task.remote(shared, path, point, steps) for point in points])
