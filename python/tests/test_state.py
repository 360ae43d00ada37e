"""The package gives the bits the `rigid` binary gives: the same --out document, the same hash,
arrays equal to the document's values, and the same error messages."""

import json

import numpy as np
import pytest
import rigid_sandbox as rs
from conftest import SCENES, rigid, rigid_error, rigid_out

# A resting stack (gravity, friction, the contact solver), jointed bodies (the document's
# joints key), and many spawned bodies in a closed box.
CASES = [("tower.ron", 300), ("double-pendulum.ron", 120), ("spawners.ron", 60)]


def arrays_of(doc):
    actors = doc["actors"]
    return {
        key: np.array([a[field] for a in actors], dtype=np.float64)
        for key, field in [
            ("positions", "position"),
            ("orientations", "orientation"),
            ("velocities", "velocity"),
            ("angular_velocities", "angular_velocity"),
        ]
    }


@pytest.mark.parametrize("scene,steps", CASES)
def test_state_and_arrays_equal_the_cli_out(tmp_path, scene, steps):
    expected = rigid_out(tmp_path, SCENES / scene, "--steps", steps)
    sim = rs.Sim.from_file(SCENES / scene)
    sim.step(steps)
    assert sim.state() == expected
    assert sim.state_hash() == expected["state_hash"]
    assert (sim.steps, sim.time, len(sim)) == (steps, expected["time"], len(expected["actors"]))
    assert sim.names == [a["name"] for a in expected["actors"]]
    for key, want in arrays_of(expected).items():
        got = getattr(sim, key)
        assert got.dtype == np.float64 and got.shape == want.shape, key
        assert np.array_equal(got, want), key


def test_run_with_set_equals_the_cli_with_set(tmp_path):
    set_ = {"actors[1].restitution": 0.8, "gravity": (0.0, -1.62, 0.0), "actors[1].position": "(0.0, 3.0, 0.0)"}
    args = ["--set", "actors[1].restitution=0.8", "--set", "gravity=(0.0, -1.62, 0.0)"]
    args += ["--set", "actors[1].position=(0.0, 3.0, 0.0)", "--steps", 100]
    expected = rigid_out(tmp_path, SCENES / "box-drop.ron", *args)
    assert rs.run(SCENES / "box-drop.ron", steps=100, set=set_) == expected
    # The overrides took: on the Moon from 3 m the box is still falling freely at t = 100/60 s.
    assert expected["actors"][1]["velocity"][1] == pytest.approx(-1.62 * 100 / 60, rel=1e-12)


def test_run_defaults_to_the_scene_steps(tmp_path):
    assert rs.run(SCENES / "box-drop.ron", threads=1) == rigid_out(tmp_path, SCENES / "box-drop.ron")


def test_from_ron_equals_from_file_and_any_thread_count():
    text = (SCENES / "spawners.ron").read_text()
    a = rs.Sim.from_ron(text, base_dir=SCENES, threads=1)
    b = rs.Sim.from_file(SCENES / "spawners.ron", threads=2)
    a.step(40)
    b.step(40)
    assert (a.threads, b.threads) == (1, 2)
    assert a.state_hash() == b.state_hash()
    assert a.state() == b.state()


def test_bench_scene_is_the_cli_bench_scene():
    sim = rs.Sim.bench("box-gas", n=1000, threads=1)
    done = rigid("bench", "box-gas", "--actors", 1000, "--steps", 1, "--warmup", 0, "--json")
    assert done.returncode == 0, done.stderr
    assert sim.state()["totals"]["kinetic_energy"] == json.loads(done.stdout)["ke_start"]
    assert len(sim) == 1000 + 6  # the cubes, then the six walls
    assert sim.names[0] == "cube-0" and sim.dt == 1 / 60
    speeds = np.linalg.norm(sim.velocities[:1000], axis=1)
    assert speeds.min() > 0 and np.all(sim.velocities[1000:] == 0)
    with pytest.raises(rs.SceneError, match="unknown benchmark scene 'gas'"):
        rs.Sim.bench("gas", n=10)


def bad_scene(tmp_path):
    path = tmp_path / "bad.ron"
    path.write_text("Scene(\n    dt: 0.01,\n    actors: [Actor(shape: Box(size: (1.0, 1.0, 1.0)), restitution: 1.5)],\n)\n")
    return path


def test_bad_scenes_raise_the_cli_message(tmp_path):
    bad = bad_scene(tmp_path)
    message = rigid_error("run", bad)
    assert str(bad) in message and "restitution" in message
    with pytest.raises(rs.SceneError) as e:
        rs.Sim.from_file(bad)
    assert str(e.value) == message
    with pytest.raises(rs.SceneError) as e:
        rs.run(bad)
    assert str(e.value) == message
    missing = tmp_path / "missing.ron"
    with pytest.raises(rs.SceneError) as e:
        rs.Sim.from_file(missing)
    assert str(e.value) == rigid_error("run", missing)
    with pytest.raises(rs.SceneError, match=r"^<string>:1:\d+: "):
        rs.Sim.from_ron("Scene(dt: 0.01, bogus: 1)")


@pytest.mark.parametrize(
    "path,value,arg",
    [
        ("actors[5].mass", 2.0, "actors[5].mass=2.0"),  # index out of range
        ("actors[1].restitution", 1.5, "actors[1].restitution=1.5"),  # outside 0..=1
        ("dt", -1, "dt=-1"),
        ("bogus", 1, "bogus=1"),
        ("dt", "0.1, steps: 5", "dt=0.1, steps: 5"),  # two values
    ],
)
def test_bad_overrides_raise_the_cli_message(path, value, arg):
    scene = SCENES / "box-drop.ron"
    message = rigid_error("run", scene, "--set", arg)
    assert message.startswith(f"--set {arg}: ")
    with pytest.raises(rs.SceneError) as e:
        rs.run(scene, set={path: value})
    assert str(e.value) == message
    with pytest.raises(rs.SceneError) as e:
        rs.Sim.from_file(scene, set={path: value})
    assert str(e.value) == message


def test_overrides_take_python_values():
    sim = rs.Sim.from_ron(
        'Scene(actors: [Actor(name: "a", shape: Box(size: (1.0, 1.0, 1.0)))])',
        set={"dt": 0.005, "steps": 3, "actors[0].velocity": (1, 2, 3), "actors[0].fixed": False},
    )
    assert sim.dt == 0.005
    assert np.array_equal(sim.velocities, [[1.0, 2.0, 3.0]])
    with pytest.raises(TypeError, match="cannot write object as a scene value"):
        rs.Sim.from_file(SCENES / "box-drop.ron", set={"dt": object()})

