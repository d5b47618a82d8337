"""`rio doctor` and the `rio_requirements` hook: what each plugin needs, broken hooks and checks reported
(never raised), and unknown names that point at the plugin to install."""

from __future__ import annotations

import json
import sys
import types
from importlib.metadata import PackageNotFoundError, distribution

import pytest

from rio.cli import main
from rio.errors import ConfigError
from rio.plugins import Registry
from rio.plugins import known as known_plugins
from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement, evaluate
from rio.testing import write_plugin_dist

from .conftest import run_rio

NEEDS = '''
from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement

@hookimpl
def rio_requirements():
    return [Requirement("rio_no_such_sdk", "pip install no-such-sdk", "the no-such arm")]
'''

CHECKS = '''
def fine():
    return None

def unhappy():
    return "no permission on /dev/ttyFAKE0"

def broken():
    raise OSError("cannot read /proc/fake")

def confused():
    return 42
'''


@pytest.fixture
def checks(tmp_path, monkeypatch):
    (tmp_path / "doctor_checks.py").write_text(CHECKS)
    monkeypatch.syspath_prepend(str(tmp_path))
    yield "doctor_checks"
    sys.modules.pop("doctor_checks", None)


def plugin_module(name: str, hook) -> types.ModuleType:
    mod = types.ModuleType(name)
    mod.rio_requirements = hookimpl(hook)
    return mod


def test_missing_module_is_listed_under_its_plugin_with_the_install_command(tmp_path):
    write_plugin_dist(tmp_path, "doc-needs", "1.0", {"doc_needs": NEEDS}, {"doc-needs": "doc_needs"})
    r = run_rio(["doctor", "--json"], tmp_path, RIO_LOAD_PLUGINS="doc-needs")
    assert r.returncode == 0, r.stderr
    data = json.loads(r.stdout)
    assert data["problems"] == []
    [row] = data["requirements"]["doc-needs"]
    assert row["module"] == "rio_no_such_sdk" and row["present"] is False and row["ok"] is False
    assert row["install"] == "pip install no-such-sdk" and row["purpose"] == "the no-such arm"
    core = {r["module"]: r for r in data["requirements"]["rio-core"]}
    assert core["copier"]["install"] == "pip install 'rio-core[new]'"
    assert "sdks" not in data and "extras" not in data

    r = run_rio(["doctor"], tmp_path, RIO_LOAD_PLUGINS="doc-needs", COLUMNS="200")
    assert r.returncode == 0, r.stderr
    assert "doc-needs needs" in r.stdout and "pip install no-such-sdk" in r.stdout


def test_raising_or_malformed_hook_is_a_problem_naming_the_plugin(registry, capsys):
    def explode():
        raise RuntimeError("requirements exploded")

    registry.register(plugin_module("doc_boom", explode), name="doc-boom", dist="doc-boom")
    registry.register(plugin_module("doc_odd", lambda: [Requirement("ok_mod", "pip install ok"), "numpy",
                                                        Requirement("not a module!")]),
                      name="doc-odd", dist="doc-odd")
    registry.register(plugin_module("doc_dict", lambda: {"numpy": "pip install numpy"}), name="doc-dict")
    assert main(["doctor", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    problems = data["problems"]
    assert any(p.startswith("plugin 'doc-boom'") and "RuntimeError: requirements exploded" in p for p in problems)
    assert any(p.startswith("plugin 'doc-odd'") and "not a rio.plugins.requirements.Requirement" in p for p in problems)
    assert any(p.startswith("plugin 'doc-odd'") and "'not a module!'" in p for p in problems)
    assert any(p.startswith("plugin 'doc-dict'") and "returned dict" in p for p in problems)
    assert "doc-boom" not in data["requirements"] and "doc-dict" not in data["requirements"]
    assert [r["module"] for r in data["requirements"]["doc-odd"]] == ["ok_mod"]  # the valid one is kept
    assert not any("unknown hook" in p for p in problems)


def test_check_results_are_shown_and_a_broken_check_never_crashes(registry, checks, capsys):
    reqs = [
        Requirement("json", "", "stdlib, check passes", check=f"{checks}:fine"),
        Requirement(None, "", "serial ports", check=f"{checks}:unhappy"),
        Requirement(None, "", "a check that raises", check=f"{checks}:broken"),
        Requirement(None, "", "a check returning junk", check=f"{checks}:confused"),
        Requirement(None, "", "a check that cannot be imported", check="doctor_no_such_mod:f"),
        Requirement("rio_no_such_sdk", "pip install x", "module missing: check not run", check=f"{checks}:broken"),
    ]
    registry.register(plugin_module("doc_checks", lambda: reqs), name="doc-checks", dist="doc-checks")
    assert main(["doctor", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["requirements"]["doc-checks"]
    fine, unhappy, broken, confused, unimportable, skipped = rows
    assert fine["ok"] and fine["present"] is True and fine["checked"] and fine["problem"] is None
    assert unhappy["present"] is None and unhappy["problem"] == "no permission on /dev/ttyFAKE0"
    assert not unhappy["ok"]
    assert broken["problem"] == f"check {checks}:broken failed: OSError: cannot read /proc/fake"
    assert "returned int" in confused["problem"]
    assert "ModuleNotFoundError" in unimportable["problem"]
    assert skipped["present"] is False and not skipped["checked"] and skipped["problem"] is None

    assert main(["doctor"]) == 0
    out = capsys.readouterr().out
    assert "doc-checks needs" in out and "/dev/ttyFAKE0" in out and "not run" in out


def test_evaluate_does_not_import_the_module(tmp_path, monkeypatch):
    marker = tmp_path / "imported"
    (tmp_path / "doctor_heavy_sdk.py").write_text(f"open({str(marker)!r}, 'w').close()\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    status = evaluate(Requirement("doctor_heavy_sdk", "pip install heavy"))
    assert status.present is True and status.ok and not marker.exists()


def _installed(dist: str) -> bool:
    try:
        distribution(dist)
    except PackageNotFoundError:
        return False
    return True


def test_install_hint_names_the_plugin_that_provides_a_name():
    hint = known_plugins.install_hint("station", "sim-so100", {"rio-core"})
    assert hint == " (provided by rio-sim, which is not installed: pip install rio-sim)"
    assert known_plugins.install_hint("station", "sim-so100", {"rio-core", "rio_sim"}) is None
    assert "pip install rio-so100" in known_plugins.install_hint("arm", "so101.follower", set())
    assert "pip install rio-so100" in known_plugins.install_hint("teleop", "so100.leader", set())
    assert "pip install rio-so100" in known_plugins.install_hint("station", "so100", set())
    assert "pip install rio-policies" in known_plugins.install_hint("policy", "openpi.remote", set())
    assert "pip install rio-datasets" in known_plugins.install_hint("dataset_format", "zarr", set())
    assert known_plugins.install_hint("station", "lab-arm", set()) is None
    assert known_plugins.install_hint("policy", "sim-so100", set()) is None  # a station name, not a policy


def test_unknown_name_in_registry_find_points_at_the_plugin(monkeypatch):
    reg = Registry(load_entry_points=False)  # core only, as with rio-sim left out by RIO_LOAD_PLUGINS
    with pytest.raises(ConfigError) as e:
        reg.find("rio_stations", "sim-so100", "station")
    # installed but not loaded: installing again would not help
    expected = "installed but not loaded" if _installed("rio-sim") else "pip install rio-sim"
    assert "unknown station 'sim-so100'" in str(e.value) and expected in str(e.value)

    monkeypatch.setitem(known_plugins.KNOWN, "rio-nosuch-plugin", {"driver": ("nosuch.*",)})
    with pytest.raises(ConfigError, match=r"provided by rio-nosuch-plugin, which is not installed: "
                                          r"pip install rio-nosuch-plugin"):
        reg.find("rio_drivers", "nosuch.arm", "arm driver")
    with pytest.raises(ConfigError) as e:
        reg.find("rio_drivers", "acme.arm", "arm driver")
    assert "provided by" not in str(e.value)


def test_plugins_of_this_repository_declare_requirements():
    reg = Registry()
    needs = reg.requirements()
    assert not [p for p in reg.problems if "rio_requirements" in p.message]
    modules = {dist: {r.module for r in reqs} for dist, reqs in needs.items()}
    assert {"zenoh", "cryptography", "copier", "av"} <= modules["rio-core"]
    for dist, expected in {"rio-so100": {"scservo_sdk"}, "rio-sim": {"mujoco"},
                           "rio-policies": {"onnxruntime", "lerobot", "torch"},
                           "rio-datasets": {"pyarrow", "h5py", "zarr", "av"}}.items():
        if dist in {p.dist for p in reg.plugins.values()}:
            assert expected <= modules[dist], dist


def _console_script_dist(root, dist: str, target: str) -> None:
    """A fake installed distribution (dist-info only) that declares a `rio` console script, as rasterio does."""
    info = root / f"{dist}-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(f"[console_scripts]\nrio = {target}\n")


def test_doctor_warns_when_another_package_also_installs_a_rio_command(tmp_path):
    r = run_rio(["doctor", "--json"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["rio_script_clashes"] == []  # rio-core's own `rio` is no clash

    _console_script_dist(tmp_path, "fakerasterio", "fakerasterio.rio.main:main_group")
    r = run_rio(["doctor", "--json"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["rio_script_clashes"] == ["fakerasterio (fakerasterio.rio.main:main_group)"]

    r = run_rio(["doctor"], tmp_path, COLUMNS="200")
    assert r.returncode == 0, r.stderr  # a warning, not a failure
    err = " ".join(r.stderr.split())
    assert "also provides a `rio` command: fakerasterio" in err and "rio-robot" in err and "python -m rio" in err
