"""`rio new plugin` and `rio new driver`: generate a plugin of every kind (and one grown to several kinds
with `rio new driver`), install them into this venv, run each one's own tests, then run each kind's
workflow through the real command line in a subprocess, as a user would:

- arm: `rio teleop --teleop scripted`, the same with `--record`, `rio replay` of the episode and
  `rio deploy --policy replay.episode` of it (the kind's FK/IK on the plugin's own robot model);
- gripper: `rio teleop --teleop scripted`; camera: the same with `--record`, its stream in the dataset;
- teleop: `rio teleop` driven by the station's own teleop role, the new device, until it finishes;
- policy: `rio deploy --policy NAME` and with the station's own `[components.policy]`;
- sensor: `rio teleop --record` with the sensor in the station.

The plugins are generated and installed once for the module; nothing in rio-core may change on the way.
"""

from __future__ import annotations

import hashlib
import importlib
import json
import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path

import numpy as np
import pytest

import rio
from rio.cli import main
from rio.plugins.scaffold import PLUGIN_KINDS

PACKAGE = Path(rio.__file__).resolve().parent
PYPROJECT = PACKAGE.parents[1] / "pyproject.toml"  # rio-core/pyproject.toml in a source checkout

# What a plugin would have to edit if discovery were an edited registry (as in the paper's PiPER
# onboarding): the core plugin, hooks, loader, stations, templates, CLI, and rio-core's pyproject.
WATCHED = ["plugins", "station", "cli"]

MULTI = "zzmulti"  # generated as a sensor plugin, then given a camera and a policy by `rio new driver`
DISTS = [f"rio-zz{k}" for k in PLUGIN_KINDS] + [f"rio-{MULTI}"]


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
    pytest.importorskip("pip", reason="needs uv or pip to install the generated plugins")
    return [sys.executable, "-m", "pip", *args]


def run(cmd: list[str], cwd: Path, timeout: float = 240) -> subprocess.CompletedProcess:
    r = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, f"{cmd} failed:\n{r.stdout}\n{r.stderr}"
    return r


def rio_cli(*args: str, cwd: Path, timeout: float = 120) -> str:
    """`python -m rio ARGS` in a subprocess; its stdout and stderr together."""
    r = run([sys.executable, "-m", "rio", *args], cwd, timeout)
    return r.stdout + r.stderr


def rio_json(*args: str, cwd: Path, timeout: float = 120) -> dict:
    """`python -m rio ARGS --json` in a subprocess; its stdout, parsed."""
    return json.loads(run([sys.executable, "-m", "rio", *args, "--json"], cwd, timeout).stdout)


def installed(dist: str) -> bool:
    importlib.invalidate_caches()
    try:
        distribution(dist)
    except PackageNotFoundError:
        return False
    return True


@dataclass
class Generated:
    root: Path
    dirs: dict[str, Path]  # kind (and MULTI) -> plugin folder
    new_driver_out: list[str]
    before: dict[str, str]


@pytest.fixture(scope="module")
def plugins(tmp_path_factory: pytest.TempPathFactory) -> Generated:
    pytest.importorskip("copier")
    root = tmp_path_factory.mktemp("plugins")
    stale = [d for d in DISTS if installed(d)]  # left by a run that was killed
    if stale:
        subprocess.run(pip("uninstall", "-q", *stale), cwd=root, capture_output=True, timeout=120)
    before = digest()
    dirs = {}
    for kind in PLUGIN_KINDS:
        assert main(["new", "plugin", f"zz{kind}", "--kind", kind, "--output", str(root)]) == 0
        dirs[kind] = root / f"rio-zz{kind}"
    assert main(["new", "plugin", MULTI, "--kind", "sensor", "--output", str(root)]) == 0
    multi = dirs[MULTI] = root / f"rio-{MULTI}"
    outs = [rio_cli("new", "driver", "wrist", "--kind", "camera", cwd=multi / "src"),  # found from a subfolder
            rio_cli("new", "driver", "hold", "--kind", "policy", "--plugin", str(multi), cwd=root)]
    run(pip("install", "-q", *[a for d in dirs.values() for a in ("-e", f"{d}[test]")]), root)
    try:
        yield Generated(root, dirs, outs, before)
    finally:
        subprocess.run(pip("uninstall", "-q", *DISTS), cwd=root, capture_output=True, timeout=120)
    gone = rio_json("plugins", "list", cwd=root)
    assert not [p for p in gone["plugins"] if p["distribution"] in DISTS]


def test_generated_plugins_are_listed(plugins):
    for kind in PLUGIN_KINDS:
        d = plugins.dirs[kind]
        pkg = d / "src" / f"rio_zz{kind}"
        assert {p.name for p in d.iterdir()} >= {"pyproject.toml", "README.md", "src", "tests"}
        assert {p.name for p in pkg.iterdir()} >= {"plugin.py", "driver.py", "emulator.py", "stations"}
    assert (plugins.dirs["arm"] / "src" / "rio_zzarm" / "models" / "arm.xml").is_file()
    listed = rio_json("plugins", "list", cwd=plugins.root)
    provides = {p["distribution"]: p["provides"] for p in listed["plugins"]}
    for kind in PLUGIN_KINDS:
        assert provides[f"rio-zz{kind}"] == {kind: [f"zz{kind}.{kind}"], "station": [f"zz{kind}-demo"]}
    assert provides[f"rio-{MULTI}"] == {
        "sensor": [f"{MULTI}.sensor"], "camera": [f"{MULTI}.wrist"], "policy": [f"{MULTI}.hold"],
        "station": [f"{MULTI}-demo", f"{MULTI}-wrist-demo", f"{MULTI}-hold-demo"]}
    assert not [p for p in listed["problems"] if p["plugin"].startswith("zz") or "zz" in p["message"]]


@pytest.mark.parametrize("kind", [*PLUGIN_KINDS, MULTI])
def test_generated_plugin_own_tests_pass(plugins, kind):
    d = plugins.dirs[kind]
    r = run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"], d, timeout=300)
    tail = r.stdout.strip().splitlines()[-1]
    hardware = 3 if kind == MULTI else 1  # one hardware test per driver, deselected by the plugin's config
    assert re.search(rf"\d+ passed, {hardware} deselected", tail), r.stdout
    assert "failed" not in tail and "error" not in tail and "skipped" not in tail, r.stdout


def test_generated_code_is_lint_clean(plugins):
    ruff = shutil.which("ruff") or (shutil.which("ruff", path=str(Path(sys.executable).parent)))
    if ruff is None:
        pytest.skip("ruff is not installed")
    for d in plugins.dirs.values():  # each with its own [tool.ruff] from the generated pyproject
        run([ruff, "check", "--no-cache", "."], d)


def test_arm_model_is_package_data(plugins, tmp_path):
    uv = shutil.which("uv")
    if uv is None:
        pytest.skip("needs uv to build the wheel")
    run([uv, "build", "--wheel", "-q", "-o", str(tmp_path), str(plugins.dirs["arm"])], tmp_path)
    import zipfile

    (wheel,) = tmp_path.glob("rio_zzarm-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert {"rio_zzarm/models/arm.xml", "rio_zzarm/stations/zzarm-demo.toml", "rio_zzarm/driver.py"} <= set(names)


# -- each kind's workflow through the command line ------------------------------------------------------


def test_arm_teleop_record_replay_deploy(plugins, tmp_path):
    out = rio_cli("teleop", "zzarm-demo", "--teleop", "scripted", "--duration", "4", cwd=tmp_path)
    m = re.search(r"arm: tool \(([-+.\d, ]+)\) -> \(([-+.\d, ]+)\) m, path ([.\d]+) m", out)
    assert m, out
    start, end = (list(map(float, g.split(","))) for g in m.groups()[:2])
    # the script's first moves: 6 cm along +y, then down towards the grasp (IK on the plugin's model)
    assert end[1] - start[1] == pytest.approx(0.06, abs=0.01) and end[2] < start[2] - 0.03, out

    data = tmp_path / "demo"
    out = rio_cli("teleop", "zzarm-demo", "--teleop", "scripted", "--duration", "4", "--record", str(data),
                  "--episodes", "1", cwd=tmp_path)
    assert "1 episode(s) kept" in out, out
    out = rio_cli("replay", str(data), "--episode", "0", "--station", "zzarm-demo", "--approach", "1", cwd=tmp_path)
    assert re.search(r"replay on 'zzarm-demo': the episode ended\n  [\d.]+ s, \d+ ticks", out), out
    pytest.importorskip("rio_policies", reason="replay.episode is registered by rio-policies")
    summary = rio_json("deploy", "zzarm-demo", "--policy", f"replay.episode,episode={data}", "--duration", "3",
                       cwd=tmp_path)
    assert summary["details"]["policy"] == "replay.episode" and summary["details"]["stats"]["chunks"] >= 1
    assert summary["details"]["metadata"]["action_dim"] == 6  # joint positions of the plugin's arm


def test_gripper_teleop(plugins, tmp_path):
    out = rio_cli("teleop", "zzgripper-demo", "--teleop", "scripted", "--duration", "4", cwd=tmp_path)
    assert "duration reached" in out and re.search(r"gripper \d+ mm", out), out


def test_camera_stream_is_recorded(plugins, tmp_path):
    from rio.recording import Dataset

    data = tmp_path / "cam"
    out = rio_cli("teleop", "zzcamera-demo", "--teleop", "scripted", "--duration", "3", "--record", str(data),
                  "--episodes", "1", cwd=tmp_path)
    assert "1 episode(s) kept" in out, out
    ep = Dataset(data).episode(0)
    assert ep.cameras == ["front"]  # the station role front_camera
    frame = next(iter(ep.frames("front")))
    assert frame.shape == (120, 160, 3)


def test_teleop_device_drives_its_station(plugins, tmp_path):
    # no --teleop: the station's own teleop role, the generated device; its emulator presses "done" after 5 s
    out = rio_cli("teleop", "zzteleop-demo", "--duration", "12", cwd=tmp_path)
    assert "with zzteleop.teleop: the device finished" in out, out
    m = re.search(r"path ([.\d]+) m", out)
    assert m and float(m.group(1)) > 0.1, out  # one lap of a ~3 cm circle


def test_policy_deploys(plugins, tmp_path):
    summary = rio_json("deploy", "zzpolicy-demo", "--policy", "zzpolicy.policy", "--duration", "3", cwd=tmp_path)
    meta = summary["details"]["metadata"]
    assert (meta["name"], meta["action_dim"], meta["horizon"], meta["cameras"]) == ("zzpolicy.policy", 6, 10, ["front"])
    assert summary["details"]["stats"]["chunks"] >= 2
    out = rio_cli("deploy", "zzpolicy-demo", "--duration", "2", cwd=tmp_path)  # the station's [components.policy]
    assert "deploy on 'zzpolicy-demo': duration reached" in out and "policy 'zzpolicy.policy'" in out, out


def test_sensor_station_records(plugins, tmp_path):
    from rio.recording import Dataset

    data = tmp_path / "ft"
    out = rio_cli("teleop", "zzsensor-demo", "--teleop", "scripted", "--duration", "3", "--record", str(data),
                  "--episodes", "1", cwd=tmp_path)
    assert "1 episode(s) kept" in out, out
    ep = Dataset(data).episode(0)
    assert ep.length > 30
    wrench = [name for name in ep.columns.dtype.names if name.startswith("meta.sensors.") and name.endswith(".wrench")]
    assert len(wrench) == 1, ep.columns.dtype.names  # every step carries the sensor's latest sample
    values = ep.column(wrench[0])
    assert values.shape == (ep.length, 6) and np.isfinite(values).all()


# -- rio new driver, names -------------------------------------------------------------------------------


def test_new_driver_registers_in_plugin_py(plugins):
    multi = plugins.dirs[MULTI]
    pkg = multi / "src" / f"rio_{MULTI}"
    camera_out, policy_out = plugins.new_driver_out
    assert f"registered in src/rio_{MULTI}/plugin.py" in camera_out and "wrist_emulator.py" in camera_out
    assert "in rio_policies():" in policy_out
    assert {p.name for p in pkg.iterdir()} >= {"wrist.py", "wrist_emulator.py", "hold.py", "hold_emulator.py"}
    text = (pkg / "plugin.py").read_text()
    assert f'Spec("{MULTI}.wrist", "camera", "rio_{MULTI}.wrist:ZzmultiWristCamera",' in text
    assert "def rio_policies() -> list[Spec]:" in text  # the hook the sensor plugin lacked was added
    assert (multi / "tests" / f"test_rio_{MULTI}_wrist.py").is_file()


def test_new_driver_refusals_and_no_register(plugins, tmp_path, capsys):
    multi = plugins.dirs[MULTI]
    assert main(["new", "driver", "wrist", "--kind", "camera", "--plugin", str(multi)]) == 1
    assert "already registers driver 'zzmulti.wrist'" in capsys.readouterr().err
    assert main(["new", "driver", "emulator", "--kind", "arm", "--plugin", str(multi)]) == 1
    assert "must be a lowercase Python module name" in capsys.readouterr().err
    assert main(["new", "driver", "x", "--kind", "arm", "--plugin", str(tmp_path)]) == 1
    assert "not inside a plugin folder" in capsys.readouterr().err

    copy = shutil.copytree(multi, tmp_path / "copy", ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    plugin_py = copy / "src" / f"rio_{MULTI}" / "plugin.py"
    text = plugin_py.read_text()
    assert main(["new", "driver", "spare", "--kind", "gripper", "--plugin", str(copy), "--no-register"]) == 0
    out = capsys.readouterr().out
    assert "not registered: --no-register" in out and f'Spec("{MULTI}.spare", "gripper",' in out
    assert plugin_py.read_text() == text and (copy / "src" / f"rio_{MULTI}" / "spare.py").is_file()


_HEAD = ("from rio.plugins.hookspecs import hookimpl\nfrom rio.plugins.specs import Spec\n\n\n"
         "@hookimpl\ndef rio_drivers():\n")
_ENTRY = 'Spec("acme.b", "arm", "m:B",\n     "second")'
_AFTER = ('    return [\n        Spec("acme.a", "arm", "m:A"),{}\n'
          '        Spec("acme.b", "arm", "m:B",\n             "second"),\n    ]\n')


@pytest.mark.parametrize("body, expected", [
    ('    return [\n        Spec("acme.a", "arm", "m:A"),\n    ]\n', _AFTER.format("")),
    ('    return [\n        Spec("acme.a", "arm", "m:A")  # no comma\n    ]\n', _AFTER.format("  # no comma")),
    ('    return [Spec("acme.a", "arm", "m:A")]\n', _AFTER.format("")),
])
def test_add_spec_edits_the_hook_list(body, expected):
    from rio.plugins.source import add_spec

    assert add_spec(_HEAD + body, "rio_drivers", _ENTRY) == _HEAD + expected
    added = add_spec(_HEAD + body, "rio_stations", 'Spec("s", "station", "m:s.toml")')
    assert added.endswith('\n\n\n@hookimpl\ndef rio_stations() -> list[Spec]:\n    return [\n'
                          '        Spec("s", "station", "m:s.toml"),\n    ]\n')


def test_add_spec_refuses_what_it_cannot_edit_safely():
    from rio.plugins.source import CannotEdit, add_spec

    for text, why in [("def rio_drivers(:\n", "does not parse"),
                      (_HEAD + "    out = []\n    return out\n", "one `return [...]`"),
                      ("import rio\n", "does not import both hookimpl and Spec")]:
        with pytest.raises(CannotEdit, match=re.escape(why)):
            add_spec(text, "rio_drivers", _ENTRY)


def test_clashing_names_are_refused(plugins, tmp_path, capsys):
    for name, expected in [("sim", "rio-sim is a plugin of the RIO repository"),
                           ("ufactory", "rio-ufactory is a plugin of the RIO repository"),  # planned
                           ("core", "is reserved"),
                           ("zzarm", "rio-zzarm 0.1.0 is already installed")]:
        assert main(["new", "plugin", name, "-o", str(tmp_path)]) == 1
        assert expected in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_nothing_in_rio_core_changed(plugins):
    assert digest() == plugins.before


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
