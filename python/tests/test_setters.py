"""Setters change the state as the scene file would have, wake sleeping bodies, and refuse bad
arrays whole."""

import numpy as np
import pytest
import rigid_sandbox as rs
from conftest import SCENES

BOX_DROP = SCENES / "box-drop.ron"


def test_set_velocities_before_a_run_equals_the_scene_saying_so():
    # The box thrown sideways by the scene file, and by the setter: the same bits after 120 steps.
    by_scene = rs.Sim.from_file(BOX_DROP, set={"actors[1].velocity": (2.0, 1.0, 0.0), "actors[1].angular_velocity": (0.0, 0.0, 3.0)})
    by_setter = rs.Sim.from_file(BOX_DROP)
    by_setter.set_velocities([[0.0, 0.0, 0.0], [2.0, 1.0, 0.0]])
    by_setter.set_angular_velocities(np.array([[0, 0, 0], [0, 0, 3]]))
    by_scene.step(120)
    by_setter.step(120)
    assert by_setter.state_hash() == by_scene.state_hash()


def test_setting_the_state_it_has_mid_run_changes_nothing():
    plain = rs.Sim.from_file(SCENES / "spawners.ron")
    touched = rs.Sim.from_file(SCENES / "spawners.ron")
    plain.step(60)
    touched.step(30)
    touched.set_positions(touched.positions)
    touched.set_velocities(touched.velocities)
    touched.set_angular_velocities(touched.angular_velocities)
    touched.step(30)
    assert touched.state_hash() == plain.state_hash()


def test_moved_body_falls_from_where_it_was_put():
    sim = rs.Sim.from_file(BOX_DROP)
    sim.step(120)  # at rest on the floor
    p = sim.positions
    p[1] = [5.0, 10.0, -2.0]
    sim.set_positions(p)
    sim.set_velocities(np.zeros((2, 3)))
    sim.set_angular_velocities(np.zeros((2, 3)))
    sim.step(1)
    g, dt = 9.81, sim.dt
    # One step of semi-implicit Euler from rest: v = -g dt, then x moves by v dt.
    assert sim.velocities[1, 1] == pytest.approx(-g * dt, rel=1e-12)
    assert sim.positions[1] == pytest.approx([5.0, 10.0 - g * dt * dt, -2.0], rel=1e-12)


def test_a_sleeping_body_wakes_when_given_a_velocity():
    sim = rs.Sim.from_file(BOX_DROP, set={"solver.sleep": True})
    sim.step(300)
    assert np.all(sim.velocities[1] == 0.0), "asleep: held exactly still"
    sim.set_velocities([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    sim.step(1)
    assert sim.positions[1, 0] > 0.0
    assert 0.0 < sim.velocities[1, 0] < 1.0  # sliding, slowed by friction


@pytest.mark.parametrize(
    "setter,array,message",
    [
        ("set_positions", np.zeros((3, 3)), r"set_positions: expected an array of shape \(2, 3\), one row per actor, got shape \[3, 3\]"),
        ("set_velocities", np.zeros((2, 4)), r"got shape \[2, 4\]"),
        ("set_angular_velocities", np.zeros(6), r"got shape \[6\]"),
        ("set_positions", [[0, 0, 0], [0, float("nan"), 0]], r"set_positions: row 1 \(actor 'box'\) is not finite"),
        ("set_velocities", [[0, 0, 0], [0, 0, float("inf")]], r"row 1 \(actor 'box'\) is not finite"),
        ("set_velocities", [[0, 1, 0], [0, 0, 0]], r"row 0: actor 'floor' is fixed, so its row must be 0"),
        ("set_angular_velocities", [[1, 0, 0], [0, 0, 0]], r"actor 'floor' is fixed"),
    ],
)
def test_bad_arrays_are_refused_whole(setter, array, message):
    sim = rs.Sim.from_file(BOX_DROP)
    before = sim.state()
    with pytest.raises(ValueError, match=message):
        getattr(sim, setter)(array)
    assert sim.state() == before


def test_a_fixed_body_can_be_moved():
    sim = rs.Sim.from_file(BOX_DROP)
    p = sim.positions
    p[0, 1] -= 1.0  # the floor drops 1 m: the box now falls 1 m further before it lands
    sim.set_positions(p)
    sim.step(40)
    assert sim.positions[0, 1] == -1.5 and sim.velocities[0, 1] == 0.0
    # Still falling at t = 0.67 s (it lands at 0.71 s), below where the old floor stopped it.
    assert -0.5 < sim.positions[1, 1] < 0.5
