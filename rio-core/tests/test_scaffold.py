"""`rio new plugin` and `rio new driver`: generate a plugin of every kind (and one grown to several kinds
with `rio new driver`), install them into a virtual environment of their own layered on this one, run
each one's own tests, then run each kind's workflow through the real command line in a subprocess, as a
user would:

- arm: `rio teleop --teleop scripted`, the same with `--record`, `rio replay` of the episode and
  `rio deploy --policy replay.episode` of it (the kind's FK/IK on the plugin's own robot model);
- gripper: `rio teleop --teleop scripted`; camera: the same with `--record`, its stream in the dataset;
- teleop: `rio teleop` driven by the station's own teleop role, the new device, until it finishes;
- policy: `rio deploy --policy NAME` and with the station's own `[components.policy]`;
- sensor: `rio teleop --record` with the sensor in the station.

The plugins are generated and installed once for the module; nothing in rio-core may change on the way.
They are not installed into the environment running the tests: tests running beside these ones (pytest-xdist
workers) list every installed plugin, and the generated ones would appear among them, then vanish.
"""

from __future__ import annotations

import hashlib
import importlib
import json
import os
import re
import shutil
import site
import subprocess
import sys
import sysconfig
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path

import numpy as np
import pytest

import rio
from rio.cli import main
from rio.plugins.scaffold import PLUGIN_KINDS
from rio.toml import read_toml

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


def pip(python: Path, *args: str) -> list[str]:
    """A `pip ARGS` command line acting on the environment of `python`."""
    uv = shutil.which("uv")
    if uv:
        return [uv, "pip", *args, "--python", str(python)]
    pytest.importorskip("pip", reason="needs uv or pip to install the generated plugins")
    return [str(python), "-m", "pip", *args]


def layered_venv(root: Path) -> Path:
    """A virtual environment at `root` that also sees everything installed in this one (a `.pth` file adds
    this environment's site directories, their `.pth` files included, after its own): what is installed
    into it stays out of this environment. Returns its python."""
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(root)], check=True, timeout=120)
    python = root / "bin" / "python"
    purelib = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                             capture_output=True, text=True, check=True, timeout=60).stdout.strip()
    ours = dict.fromkeys([*site.getsitepackages(), sysconfig.get_paths()["purelib"]])
    (Path(purelib) / "_rio_tests_layered_on.pth").write_text("".join(f"import site; site.addsitedir({d!r})\n"
                                                                    for d in ours))
    return python


def unmet_requirements(plugin: Path) -> list[str]:
    """The dependencies of the generated plugin at `plugin` that this environment does not satisfy: its
    install into the layered environment skips dependencies (the installer sees only that environment's own
    site directory and would fetch rio-core again), so they are checked here."""
    from packaging.requirements import Requirement

    deps = read_toml(plugin / "pyproject.toml")["project"]["dependencies"]
    unmet = []
    for dep in map(Requirement, deps):
        try:
            version = distribution(dep.name).version
        except PackageNotFoundError:
            unmet.append(f"{dep} (not installed)")
            continue
        if not dep.specifier.contains(version, prereleases=True):
            unmet.append(f"{dep} (installed: {version})")
    return unmet


def run(cmd: list[str], cwd: Path, timeout: float = 240) -> subprocess.CompletedProcess:
    r = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, f"{cmd} failed:\n{r.stdout}\n{r.stderr}"
    return r


def rio_cli(python: Path, *args: str, cwd: Path, timeout: float = 120) -> str:
    """`python -m rio ARGS` in a subprocess; its stdout and stderr together."""
    r = run([str(python), "-m", "rio", *args], cwd, timeout)
    return r.stdout + r.stderr


def rio_json(python: Path, *args: str, cwd: Path, timeout: float = 120) -> dict:
    """`python -m rio ARGS --json` in a subprocess; its stdout, parsed."""
    return json.loads(run([str(python), "-m", "rio", *args, "--json"], cwd, timeout).stdout)


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
    python: Path  # of the layered environment the plugins are installed in
    dirs: dict[str, Path]  # kind (and MULTI) -> plugin folder
    new_driver_out: list[str]
    before: dict[str, str]

    def rio(self, *args: str, cwd: Path, timeout: float = 120) -> str:
        return rio_cli(self.python, *args, cwd=cwd, timeout=timeout)

    def rio_json(self, *args: str, cwd: Path, timeout: float = 120) -> dict:
        return rio_json(self.python, *args, cwd=cwd, timeout=timeout)


@pytest.fixture(scope="module")
def plugins(tmp_path_factory: pytest.TempPathFactory) -> Generated:
    pytest.importorskip("copier")
    root = tmp_path_factory.mktemp("plugins")
    stale = [d for d in DISTS if installed(d)]  # installed here by a run before they had an environment of their own
    if stale:
        subprocess.run(pip(Path(sys.executable), "uninstall", "-q", *stale), cwd=root, capture_output=True, timeout=120)
    python = layered_venv(tmp_path_factory.mktemp("venv"))
    before = digest()
    dirs = {}
    for kind in PLUGIN_KINDS:
        assert main(["new", "plugin", f"zz{kind}", "--kind", kind, "--output", str(root)]) == 0
        dirs[kind] = root / f"rio-zz{kind}"
    assert main(["new", "plugin", MULTI, "--kind", "sensor", "--output", str(root)]) == 0
    multi = dirs[MULTI] = root / f"rio-{MULTI}"
    outs = [rio_cli(python, "new", "driver", "wrist", "--kind", "camera", cwd=multi / "src"),  # found from a subfolder
            rio_cli(python, "new", "driver", "hold", "--kind", "policy", "--plugin", str(multi), cwd=root)]
    assert {kind: unmet_requirements(d) for kind, d in dirs.items()} == {kind: [] for kind in dirs}
    run(pip(python, "install", "-q", "--no-deps", *[a for d in dirs.values() for a in ("-e", str(d))]), root)
    assert not [d for d in DISTS if installed(d)], "installed into the environment running the tests"
    try:
        yield Generated(root, python, dirs, outs, before)
    finally:
        subprocess.run(pip(python, "uninstall", "-q", *DISTS), cwd=root, capture_output=True, timeout=120)
    gone = rio_json(python, "plugins", "list", cwd=root)
    assert not [p for p in gone["plugins"] if p["distribution"] in DISTS]


@pytest.mark.slow
def test_generated_plugins_are_listed(plugins):
    for kind in PLUGIN_KINDS:
        d = plugins.dirs[kind]
        pkg = d / "src" / f"rio_zz{kind}"
        assert {p.name for p in d.iterdir()} >= {"pyproject.toml", "README.md", "src", "tests"}
        assert {p.name for p in pkg.iterdir()} >= {"plugin.py", "driver.py", "emulator.py", "stations"}
    assert (plugins.dirs["arm"] / "src" / "rio_zzarm" / "models" / "arm.xml").is_file()
    listed = plugins.rio_json("plugins", "list", cwd=plugins.root)
    provides = {p["distribution"]: p["provides"] for p in listed["plugins"]}
    for kind in PLUGIN_KINDS:
        assert provides[f"rio-zz{kind}"] == {kind: [f"zz{kind}.{kind}"], "station": [f"zz{kind}-demo"]}
    assert provides[f"rio-{MULTI}"] == {
        "sensor": [f"{MULTI}.sensor"], "camera": [f"{MULTI}.wrist"], "policy": [f"{MULTI}.hold"],
        "station": [f"{MULTI}-demo", f"{MULTI}-wrist-demo", f"{MULTI}-hold-demo"]}
    assert not [p for p in listed["problems"] if p["plugin"].startswith("zz") or "zz" in p["message"]]


@pytest.mark.slow
@pytest.mark.parametrize("kind", [*PLUGIN_KINDS, MULTI])
def test_generated_plugin_own_tests_pass(plugins, kind):
    d = plugins.dirs[kind]
    r = run([str(plugins.python), "-m", "pytest", "-q", "-p", "no:cacheprovider"], d, timeout=300)
    tail = r.stdout.strip().splitlines()[-1]
    hardware = 3 if kind == MULTI else 1  # one hardware test per driver, deselected by the plugin's config
    assert re.search(rf"\d+ passed, {hardware} deselected", tail), r.stdout
    assert "failed" not in tail and "error" not in tail and "skipped" not in tail, r.stdout


@pytest.mark.slow
def test_generated_code_is_lint_clean(plugins):
    ruff = shutil.which("ruff") or (shutil.which("ruff", path=str(Path(sys.executable).parent)))
    if ruff is None:
        pytest.skip("ruff is not installed")
    for d in plugins.dirs.values():  # each with its own [tool.ruff] from the generated pyproject
        run([ruff, "check", "--no-cache", "."], d)


@pytest.mark.slow
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


@pytest.mark.slow
def test_arm_teleop_record_replay_deploy(plugins, tmp_path):
    out = plugins.rio("teleop", "zzarm-demo", "--teleop", "scripted", "--duration", "4", cwd=tmp_path)
    m = re.search(r"arm: tool \(([-+.\d, ]+)\) -> \(([-+.\d, ]+)\) m, path ([.\d]+) m", out)
    assert m, out
    start, end = (list(map(float, g.split(","))) for g in m.groups()[:2])
    # the script's first moves: 6 cm along +y, then down towards the grasp (IK on the plugin's model)
    assert end[1] - start[1] == pytest.approx(0.06, abs=0.01) and end[2] < start[2] - 0.03, out

    data = tmp_path / "demo"
    out = plugins.rio("teleop", "zzarm-demo", "--teleop", "scripted", "--duration", "4", "--record", str(data),
                  "--episodes", "1", cwd=tmp_path)
    assert "1 episode(s) kept" in out, out
    out = plugins.rio("replay", str(data), "--episode", "0", "--station", "zzarm-demo", "--approach", "1", cwd=tmp_path)
    assert re.search(r"replay on 'zzarm-demo': the episode ended\n  [\d.]+ s, \d+ ticks", out), out
    pytest.importorskip("rio_policies", reason="replay.episode is registered by rio-policies")
    summary = plugins.rio_json("deploy", "zzarm-demo", "--policy", f"replay.episode,episode={data}", "--duration", "3",
                       cwd=tmp_path)
    assert summary["details"]["policy"] == "replay.episode" and summary["details"]["stats"]["chunks"] >= 1
    assert summary["details"]["metadata"]["action_dim"] == 6  # joint positions of the plugin's arm


@pytest.mark.slow
def test_gripper_teleop(plugins, tmp_path):
    out = plugins.rio("teleop", "zzgripper-demo", "--teleop", "scripted", "--duration", "4", cwd=tmp_path)
    assert "duration reached" in out and re.search(r"gripper \d+ mm", out), out


@pytest.mark.slow
def test_camera_stream_is_recorded(plugins, tmp_path):
    from rio.recording import Dataset

    data = tmp_path / "cam"
    out = plugins.rio("teleop", "zzcamera-demo", "--teleop", "scripted", "--duration", "3", "--record", str(data),
                  "--episodes", "1", cwd=tmp_path)
    assert "1 episode(s) kept" in out, out
    ep = Dataset(data).episode(0)
    assert ep.cameras == ["front"]  # the station role front_camera
    frame = next(iter(ep.frames("front")))
    assert frame.shape == (120, 160, 3)


@pytest.mark.slow
def test_teleop_device_drives_its_station(plugins, tmp_path):
    # no --teleop: the station's own teleop role, the generated device; its emulator presses "done" after 5 s
    out = plugins.rio("teleop", "zzteleop-demo", "--duration", "12", cwd=tmp_path)
    assert "with zzteleop.teleop: the device finished" in out, out
    m = re.search(r"path ([.\d]+) m", out)
    assert m and float(m.group(1)) > 0.1, out  # one lap of a ~3 cm circle


@pytest.mark.slow
def test_policy_deploys(plugins, tmp_path):
    summary = plugins.rio_json("deploy", "zzpolicy-demo", "--policy", "zzpolicy.policy", "--duration", "3",
                               cwd=tmp_path)
    meta = summary["details"]["metadata"]
    assert (meta["name"], meta["action_dim"], meta["horizon"], meta["cameras"]) == ("zzpolicy.policy", 6, 10, ["front"])
    assert summary["details"]["stats"]["chunks"] >= 2
    out = plugins.rio("deploy", "zzpolicy-demo", "--duration", "2", cwd=tmp_path)  # the station's [components.policy]
    assert "deploy on 'zzpolicy-demo': duration reached" in out and "policy 'zzpolicy.policy'" in out, out


@pytest.mark.slow
def test_sensor_station_records(plugins, tmp_path):
    from rio.recording import Dataset

    data = tmp_path / "ft"
    out = plugins.rio("teleop", "zzsensor-demo", "--teleop", "scripted", "--duration", "3", "--record", str(data),
                  "--episodes", "1", cwd=tmp_path)
    assert "1 episode(s) kept" in out, out
    ep = Dataset(data).episode(0)
    assert ep.length > 30
    wrench = [name for name in ep.columns.dtype.names if name.startswith("meta.sensors.") and name.endswith(".wrench")]
    assert len(wrench) == 1, ep.columns.dtype.names  # every step carries the sensor's latest sample
    values = ep.column(wrench[0])
    assert values.shape == (ep.length, 6) and np.isfinite(values).all()


# -- rio new driver, names -------------------------------------------------------------------------------


@pytest.mark.slow
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


@pytest.mark.slow
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


@pytest.mark.slow
def test_clashing_names_are_refused(plugins, tmp_path, capsys):
    for name, expected in [("sim", "rio-sim is a plugin of the RIO repository"),
                           ("ufactory", "rio-ufactory is a plugin of the RIO repository"),  # planned
                           ("core", "is reserved")]:
        assert main(["new", "plugin", name, "-o", str(tmp_path)]) == 1
        assert expected in capsys.readouterr().err
    # installed in the plugins' own environment: asked there
    r = subprocess.run([str(plugins.python), "-m", "rio", "new", "plugin", "zzarm", "-o", str(tmp_path)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 1 and "rio-zzarm 0.1.0 is already installed" in r.stderr, r.stdout + r.stderr
    assert not list(tmp_path.iterdir())


@pytest.mark.slow
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
