"""Sweeps: the grid's points in order, the same bits on Ray (a local cluster of two workers)
as on this machine's threads and as `rigid run --set`, bad points refused before any runs."""

import csv
import subprocess
import sys

import pytest
import rigid_sandbox as rs
from conftest import ROOT, SCENES, rigid_error, rigid_out
from rigid_sandbox.sweep import grid_points

BOX_DROP = SCENES / "box-drop.ron"
# A bouncy floor (one value), three boxes, two heights: 50 steps end just after the bounces.
GRID = {
    "actors[0].restitution": [1.0],
    "actors[1].restitution": [0.2, 0.6, 1.0],
    "actors[1].position": [(0.0, 2.0, 0.0), (0.0, 3.0, 0.0)],
}
STEPS = 50


@pytest.fixture(scope="module")
def ray_cluster():
    ray = pytest.importorskip("ray")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield ray
    ray.shutdown()


def test_grid_points_vary_the_first_key_slowest():
    assert grid_points({"a": [1, 2], "b": ["x", "y", "z"]}) == [
        {"a": 1, "b": "x"}, {"a": 1, "b": "y"}, {"a": 1, "b": "z"},
        {"a": 2, "b": "x"}, {"a": 2, "b": "y"}, {"a": 2, "b": "z"},
    ]
    with pytest.raises(TypeError, match=r"grid\['a'\] must be a list of values"):
        grid_points({"a": 0.5})


def test_local_sweep_equals_runs_one_by_one(tmp_path):
    results = rs.sweep(BOX_DROP, GRID, steps=STEPS, backend="local", threads=2)
    assert [r["set"] for r in results] == grid_points(GRID)
    for r in results:
        assert r["state"] == rs.run(BOX_DROP, steps=STEPS, set=r["set"])
    # Against the binary for one point; every point bounced its own way.
    args = ["--set", "actors[0].restitution=1.0", "--set", "actors[1].restitution=1.0"]
    args += ["--set", "actors[1].position=(0.0, 3.0, 0.0)", "--steps", STEPS]
    assert results[5]["state"] == rigid_out(tmp_path, BOX_DROP, *args)
    hashes = {r["state"]["state_hash"] for r in results}
    assert len(hashes) == len(results)


def test_ray_sweep_equals_the_local_sweep(ray_cluster):
    local = rs.sweep(BOX_DROP, GRID, steps=STEPS, backend="local")
    on_ray = rs.sweep(BOX_DROP, GRID, steps=STEPS, backend="ray")
    assert on_ray == local
    # The sweep joined the cluster the test started instead of starting its own.
    assert ray_cluster.cluster_resources()["CPU"] == 2


@pytest.mark.parametrize("backend", ["local", "ray"])
def test_a_bad_point_is_refused_before_any_runs(backend, request):
    if backend == "ray":
        request.getfixturevalue("ray_cluster")
    grid = {"actors[1].restitution": [0.5, 1.5]}
    with pytest.raises(rs.SceneError) as e:
        rs.sweep(BOX_DROP, grid, steps=10, backend=backend)
    assert str(e.value) == rigid_error("run", BOX_DROP, "--set", "actors[1].restitution=1.5")


def test_a_failing_point_raises_its_error_from_the_worker(ray_cluster):
    # Valid text, but the box's mesh file is missing: found only when a worker builds it.
    grid = {"actors[1].shape": ['Obj(path: "no-such-mesh.obj")']}
    for backend in ["local", "ray"]:
        with pytest.raises(rs.SceneError, match="no-such-mesh.obj"):
            rs.sweep(BOX_DROP, grid, steps=1, backend=backend)


def test_unknown_backend():
    with pytest.raises(ValueError, match="backend must be one of 'ray', 'local', got 'dask'"):
        rs.sweep(BOX_DROP, GRID, backend="dask")


def test_the_example_writes_its_table_and_plot(tmp_path):
    done = subprocess.run(
        [sys.executable, ROOT / "examples" / "sweep_restitution.py", "--backend", "local", "--steps", "20",
         "--out", tmp_path],
        capture_output=True, text=True, cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    rows = list(csv.DictReader(open(tmp_path / "sweep_restitution.csv")))
    assert len(rows) == 12  # 4 restitutions x 3 counts
    assert {int(r["rocks"]) for r in rows} == {27, 125, 343}
    assert all(float(r["kinetic_energy_end"]) <= float(r["kinetic_energy_start"]) for r in rows)
    plot = tmp_path / "sweep_restitution.svg"
    assert plot.exists() and plot.read_text().lstrip().startswith(("<?xml", "<svg"))
