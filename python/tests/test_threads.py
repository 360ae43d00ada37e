"""`step` releases the GIL: two threads stepping two sims run at the same time, and the main
thread keeps running Python meanwhile."""

import threading
import time

import rigid_sandbox as rs

# Long enough that thread start-up and the OS's time slices are small beside it.
TARGET_SECONDS = 0.8


def steps_for(seconds):
    """Steps of the test's sim (one thread) that take about `seconds` here and now."""
    sim = rs.Sim.bench("box-gas", n=1000, threads=1)
    start = time.perf_counter()
    sim.step(10)
    per_step = (time.perf_counter() - start) / 10
    return max(10, int(seconds / per_step))


def test_two_threads_step_at_once_while_python_runs():
    n = steps_for(TARGET_SECONDS)
    sims = [rs.Sim.bench("box-gas", n=1000, threads=1) for _ in range(2)]
    barrier = threading.Barrier(3)
    spans = [None, None]

    def work(k):
        barrier.wait()
        start = time.perf_counter()
        sims[k].step(n)
        spans[k] = (start, time.perf_counter())

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    barrier.wait()
    # The main thread ticks while the others step: a step holding the GIL would stop it for
    # the whole step.
    ticks = [time.perf_counter()]
    while any(t.is_alive() for t in threads):
        time.sleep(0.002)
        ticks.append(time.perf_counter())
    for t in threads:
        t.join()
    (a0, a1), (b0, b1) = spans
    shorter = min(a1 - a0, b1 - b0)
    overlap = min(a1, b1) - max(a0, b0)
    assert overlap > 0.5 * shorter, f"steps overlapped {overlap:.3f} s of {shorter:.3f} s"
    inside = [t for t in ticks if max(a0, b0) <= t <= min(a1, b1)]
    gaps = [b - a for a, b in zip(inside, inside[1:])]
    assert len(inside) > 10 and max(gaps) < 0.25 * shorter, (
        f"the main thread stalled {max(gaps, default=shorter):.3f} s during steps of {shorter:.3f} s"
    )
    assert sims[0].state_hash() == sims[1].state_hash()  # same scene, same bits, side by side


def test_ctrl_c_stops_a_long_step_at_a_step_boundary():
    import os
    import signal

    import pytest

    sim = rs.Sim.bench("box-gas", n=1000, threads=1)
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    start = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        sim.step(10**9)
    waited = time.perf_counter() - start
    timer.join()
    assert 0 < sim.steps < 10**9 and sim.time == sim.steps * sim.dt
    assert waited < 0.3 + 2.0, f"stopped {waited - 0.3:.2f} s after Ctrl-C"
    done = sim.steps
    sim.step(2)  # and it goes on from there
    assert sim.steps == done + 2
