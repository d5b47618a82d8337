"""`rio new plugin`: generate every kind, install them into this venv, see them listed, run their own
tests, build a station with one, and check that nothing in rio-core was edited along the way."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import rio
from rio.cli import main
from rio.scaffold import PLUGIN_KINDS

PACKAGE = Path(rio.__file__).resolve().parent
PYPROJECT = PACKAGE.parents[1] / "pyproject.toml"  # rio-core/pyproject.toml in a source checkout


# What a plugin would have to edit if discovery were an edited registry (as in the paper's PiPER
# onboarding): the core plugin, hooks, loader, stations, templates, CLI, and rio-core's pyproject.
WATCHED = ["builtin_plugin.py", "plugins.py", "hookspecs.py", "specs.py", "station", "templates", "cli"]


def digest() -> dict[str, str]:
    """Content hash of the watched files of the installed rio package."""
    files = [PACKAGE / w for w in WATCHED if (PACKAGE / w).is_file()]
    files += [p for w in WATCHED for p in (PACKAGE / w).rglob("*") if p.is_file() and "__pycache__" not in p.parts]
    files += [PYPROJECT] if PYPROJECT.is_file() else []
    return {str(p): hashlib.sha256(p.read_bytes()).hexdigest() for p in files}


def pip(*args: str) -> list[str]:
    uv = shutil.which("uv")
    if uv:
        return [uv, "pip", *args, "--python", sys.executable]
    pytest.importorskip("pip", reason="needs uv or pip to install the generated plugin")
    return [sys.executable, "-m", "pip", *args]


def run(cmd: list[str], cwd: Path, timeout: float = 240) -> subprocess.CompletedProcess:
    r = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, f"{cmd} failed:\n{r.stdout}\n{r.stderr}"
    return r


STEP_SCRIPT = """
import numpy as np
from rio import ServerManager, time
from rio.station import make_station
servers, clients, env = make_station("zzarm-demo", middleware="thread")
with ServerManager(servers), env:
    env.reset()
    target = np.full(env.action_dim, 0.1)
    for _ in range(50):
        step = env.step(target, t_cmd_target=time.now() + 0.02)
        time.precise_wait(time.now() + 0.02)
    print("proprio", step.observation.proprio.round(3).tolist(), "timestep", step.timestep)
"""


def test_generated_plugins_install_list_test_and_run(tmp_path):
    pytest.importorskip("copier")
    before = digest()
    dirs = []
    for kind in PLUGIN_KINDS:
        assert main(["new", "plugin", f"zz{kind}", "--kind", kind, "--output", str(tmp_path)]) == 0
        d = tmp_path / f"rio-zz{kind}"
        assert {p.name for p in d.iterdir()} >= {"pyproject.toml", "README.md", "src", "tests"}
        dirs.append(d)
    installs = [a for d in dirs for a in ("-e", str(d))]
    run(pip("install", "-q", *installs), tmp_path)
    try:
        listed = json.loads(run([sys.executable, "-m", "rio", "plugins", "list", "--json"], tmp_path).stdout)
        provides = {p["distribution"]: p["provides"] for p in listed["plugins"]}
        for kind in PLUGIN_KINDS:
            assert provides[f"rio-zz{kind}"] == {kind: [f"zz{kind}.{kind}"], "station": [f"zz{kind}-demo"]}
        assert not [p for p in listed["problems"] if p["plugin"].startswith("zz")]

        tests = [str(d / "tests") for d in dirs]
        r = run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--import-mode=importlib", *tests],
                tmp_path)
        assert f"{3 * len(PLUGIN_KINDS)} passed" in r.stdout

        out = run([sys.executable, "-c", STEP_SCRIPT], tmp_path).stdout
        assert "proprio [0.1, 0.1, 0.1, 0.1, 0.1, 0.1] timestep 50" in out
    finally:
        subprocess.run(pip("uninstall", "-q", *[f"rio-zz{k}" for k in PLUGIN_KINDS]), cwd=tmp_path,
                       capture_output=True, timeout=120)
    assert digest() == before
    gone = json.loads(run([sys.executable, "-m", "rio", "plugins", "list", "--json"], tmp_path).stdout)
    assert not [p for p in gone["plugins"] if p["distribution"].startswith("rio-zz")]


def test_new_plugin_errors(tmp_path, capsys, monkeypatch):
    assert main(["new", "plugin", "Bad Name", "-o", str(tmp_path)]) == 1
    assert "must be lowercase letters" in capsys.readouterr().err
    assert main(["new", "plugin", "ok", "--kind", "grippr", "-o", str(tmp_path)]) == 1
    assert "unknown plugin kind 'grippr'; did you mean 'gripper'?" in capsys.readouterr().err
    (tmp_path / "rio-taken").mkdir()
    (tmp_path / "rio-taken" / "keep.txt").write_text("mine")
    assert main(["new", "plugin", "taken", "-o", str(tmp_path)]) == 1
    assert "already exists and is not empty" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "copier", None)  # as if not installed
    assert main(["new", "plugin", "fresh", "-o", str(tmp_path)]) == 1
    assert "pip install 'rio-core[new]'" in capsys.readouterr().err
    assert not (tmp_path / "rio-fresh").exists()
    assert os.listdir(tmp_path / "rio-taken") == ["keep.txt"]
