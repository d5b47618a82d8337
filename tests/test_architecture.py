"""rio-core's floors hold (docs/architecture.md): the import-linter contracts in the root pyproject.toml pass,
they name every top-level package and module of `rio` (so no unit escapes the layering and no two units can
import each other in a cycle), `rio/` itself holds at most 12 modules, and listing plugins stays cheap: with
every plugin of this repository installed, `rio plugins list` imports no numpy, no vendor SDK and no driver."""

from __future__ import annotations

import importlib.util
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parent.parent
RIO = ROOT / "rio-core" / "src" / "rio"


def _contracts() -> list[dict]:
    return tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["importlinter"]["contracts"]


def _units() -> set[str]:
    """Every top-level unit of rio: its subpackages and its modules (`rio.__init__` is the container)."""
    out = {f"rio.{p.name}" for p in RIO.iterdir() if p.is_dir() and (p / "__init__.py").is_file()}
    return out | {f"rio.{p.stem}" for p in RIO.glob("*.py") if p.name != "__init__.py"}


def test_the_layer_contracts_hold():
    if importlib.util.find_spec("importlinter") is None:
        pytest.skip("import-linter is not installed (the dev environment has it: uv sync --all-extras)")
    exe = shutil.which("lint-imports", path=str(Path(sys.executable).parent)) or shutil.which("lint-imports")
    assert exe, "import-linter is installed but its lint-imports command is not on PATH"
    r = subprocess.run([exe, "--no-cache"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, f"an import breaks rio-core's floors (docs/architecture.md):\n{r.stdout[-4000:]}"
    assert "broken" not in r.stdout.split("Contracts:")[-1].replace("0 broken", "")


def test_every_unit_of_rio_is_on_a_floor():
    layers = next(c for c in _contracts() if c["type"] == "layers")["layers"]
    named = {u.strip() for layer in layers for u in layer.split("|")}
    assert named == _units(), ("a package or module of rio is missing from the layers contract in pyproject.toml "
                               "(or the contract names one that no longer exists): "
                               f"unlisted {sorted(_units() - named)}, gone {sorted(named - _units())}")


def test_rio_holds_at_most_twelve_modules_directly():
    modules = sorted(p.name for p in RIO.glob("*.py"))
    assert len(modules) <= 12, f"rio/ holds {len(modules)} modules; put new ones in the package of their floor"


def test_every_middleware_backend_is_in_the_independence_contract():
    backends = next(c for c in _contracts() if c["type"] == "independence")["modules"]
    shipped = {f"rio.middleware.{s}" for s in ("thread", "shm", "zmq", "zenoh", "portal")}
    assert set(backends) == shipped


#: Top-level modules a vendor SDK or heavy library installs; `rio plugins list` must import none of them.
HEAVY = ("numpy", "scipy", "mujoco", "mink", "pinocchio", "cv2", "av", "torch", "onnxruntime", "zmq", "zenoh",
         "xarm", "rtde_control", "rtde_receive", "scservo_sdk", "dynamixel_sdk", "can", "canopen", "pyrealsense2",
         "franky", "pylibfranka", "kortex_api", "unitree_sdk2py", "cyclonedds", "booster_robotics_sdk_python",
         "depthai", "pyspacemouse", "hid", "pygame", "rerun", "pyarrow", "zarr", "h5py", "websockets")


def test_listing_plugins_imports_no_sdk_numpy_or_driver():
    """Every plugin's entry module and CLI module stay cheap: names and import paths only. A driver module
    imports rio's node runtime (`rio.runtime.node`) or a kind (`rio.interfaces`), so either one being imported
    means some plugin pulled a driver in."""
    code = ("import sys, io, json, contextlib\nfrom rio.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n    rc = main(['plugins', 'list'])\n"
            "print(json.dumps({'rc': rc, 'modules': sorted(sys.modules)}))")
    env = {k: v for k, v in os.environ.items() if k != "RIO_LOAD_PLUGINS"}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout.splitlines()[-1])
    assert out["rc"] == 0
    mods = set(out["modules"])
    tops = {m.split(".")[0] for m in mods}
    assert not tops & set(HEAVY), f"rio plugins list imported {sorted(tops & set(HEAVY))}"
    drivers = sorted(m for m in mods if m == "rio.runtime.node" or m.startswith("rio.interfaces"))
    assert not drivers, f"rio plugins list imported driver code: {drivers}"
