"""Shared helpers: the repository's paths and the `rigid` binary the package is compared with."""

import json
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCENES = ROOT / "scenes"
RIGID = Path(os.environ.get("RIGID_BIN", ROOT / "target" / "release" / "rigid"))


def rigid(*args):
    """Runs `rigid ARGS`; returns the completed process (stdout and stderr as text)."""
    if not RIGID.exists():
        pytest.fail(f"{RIGID} is missing: build it with `cargo build --release` (python/test.sh does)")
    return subprocess.run([str(RIGID), *map(str, args)], capture_output=True, text=True, cwd=ROOT)


def rigid_out(tmp_path, scene, *args):
    """The `--out` document of `rigid run SCENE ARGS`, as a dict."""
    out = tmp_path / "out.json"
    done = rigid("run", scene, "--quiet", "--out", out, *args)
    assert done.returncode == 0, done.stderr
    return json.loads(out.read_text())


def rigid_error(*args):
    """The message of a `rigid` run that fails as bad input, without its `error: ` prefix."""
    done = rigid(*args)
    assert done.returncode == 2, (done.returncode, done.stdout, done.stderr)
    line = done.stderr.strip().splitlines()[-1]
    assert line.startswith("error: "), done.stderr
    return line[len("error: "):]
