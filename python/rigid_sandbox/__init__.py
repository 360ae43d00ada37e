"""rigid-sandbox from Python: load a scene, step it with the GIL released, read and write the
state of every body as numpy arrays, and sweep parameters on Ray or on this machine's cores.

    import rigid_sandbox as rs
    sim = rs.Sim.from_file("scenes/tower.ron")
    sim.step(600)
    sim.positions            # (N, 3) float64
    rs.run("scenes/box-drop.ron", set={"actors[1].restitution": 0.8})

See docs/python.md.
"""

import json as _json
import os as _os

from ._native import SceneError, Sim, SimulationError
from ._native import run_scene as _run_scene
from .sweep import sweep

__all__ = ["Sim", "SceneError", "SimulationError", "run", "sweep"]


def run(scene, steps=None, set=None, threads=None):
    """Runs the scene file `scene` for `steps` steps (default: the scene's `steps`) with the
    overrides `set` ({"PATH": value}, as `rigid run --set PATH=VALUE`) and returns the final
    state, the document `rigid run --out` writes, as a dict."""
    return _json.loads(_run_scene(_os.fspath(scene), set=set, steps=steps, threads=threads))
