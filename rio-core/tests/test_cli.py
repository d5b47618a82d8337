"""The `rio` command line: listings (human and --json), errors, doctor, bench pass-through, plugin commands."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import types

import pytest
import typer

import rio
from rio.cli import main
from rio.plugins.hookspecs import hookimpl
from rio.plugins.specs import Spec
from rio.testing import write_plugin_dist

from .conftest import run_rio

GOOD = '''
from rio.plugins.hookspecs import hookimpl
from rio.plugins.specs import Spec

@hookimpl
def rio_drivers():
    return [Spec("acme.arm", "arm", "cli_good_driver:AcmeArm", "an arm")]
'''
DRIVER = "import numpy\nraise RuntimeError('the driver module must not be imported by a listing')\n"


@pytest.fixture(scope="module")
def dist_path(tmp_path_factory):
    root = tmp_path_factory.mktemp("cli_dists")
    write_plugin_dist(root, "cli-good", "2.0", {"cli_good": GOOD, "cli_good_driver": DRIVER}, {"cli-good": "cli_good"})
    write_plugin_dist(root, "cli-broken", "0.1", {"cli_broken": "raise ImportError('vendor SDK missing')\n"},
                      {"cli-broken": "cli_broken"})
    return root


def test_version(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out == f"rio {rio.__version__}\n"


def test_plugins_list_json_names_broken_plugins(dist_path):
    r = run_rio(["plugins", "list", "--json"], dist_path)
    assert r.returncode == 0, r.stderr
    data = json.loads(r.stdout)
    by_name = {p["distribution"]: p for p in data["plugins"]}
    assert by_name["cli-good"]["version"] == "2.0"
    assert by_name["cli-good"]["provides"] == {"arm": ["acme.arm"]}
    assert "thread" in by_name["rio-core"]["provides"]["middleware"]
    assert "cli-broken" not in by_name
    broken = [p for p in data["problems"] if p["plugin"] == "cli-broken"]
    assert broken and "vendor SDK missing" in broken[0]["message"]


def test_plugins_list_table_and_rio_load_plugins(dist_path):
    r = run_rio(["plugins", "list"], dist_path, RIO_LOAD_PLUGINS="cli-good", COLUMNS="200")
    assert r.returncode == 0, r.stderr
    assert "cli-good" in r.stdout and "2.0" in r.stdout and "arm: acme.arm" in r.stdout
    assert "cli-broken" not in r.stdout + r.stderr


def test_listing_imports_no_driver_and_no_runtime(dist_path):
    """What keeps `rio plugins list` fast: no driver module, no numpy, no middleware or station code."""
    code = ("import sys, io, contextlib, json\nfrom rio.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n    rc = main(['plugins', 'list'])\n"
            "heavy = ['numpy', 'cli_good_driver', 'rio.runtime.manager', 'rio.station', 'rio.middleware.thread',\n"
            "         'rio.runtime.node']\n"
            "print(json.dumps({'rc': rc, 'imported': [m for m in heavy if m in sys.modules]}))")
    # only core and the test plugin: other installed plugins answer for their own import cost
    env = {**os.environ, "PYTHONPATH": str(dist_path), "RIO_LOAD_PLUGINS": "cli-good"}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=60)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout.splitlines()[-1]) == {"rc": 0, "imported": []}


def test_drivers_list_by_kind(registry, capsys):
    assert main(["drivers", "list", "--kind", "camera", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [(r["name"], r["kind"], r["plugin"]) for r in rows] == [("rio.fake_camera", "camera", "rio-core")]
    assert main(["drivers", "list", "--kind", "amr"]) == 1
    assert "unknown kind 'amr'; did you mean 'arm'?" in capsys.readouterr().err


def test_stations_list_and_check(registry, tmp_path, capsys):
    good = tmp_path / "good.toml"
    good.write_text('name = "g"\n[middleware]\nname = "thread"\n[components.arm]\ndriver = "rio.fake_arm"\n')
    mod = types.ModuleType("cli_station_plugin")
    mod.rio_stations = hookimpl(lambda: [Spec("lab-arm", "station", str(good), "a lab arm")])
    registry.register(mod, name="cli-stations", dist="rio-lab")
    assert main(["stations", "list", "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == [
        {"name": "lab-arm", "plugin": "rio-lab", "target": str(good), "description": "a lab arm",
         "formerly": []}]

    assert main(["stations", "check", "lab-arm"]) == 0
    out = capsys.readouterr().out
    assert "embodiment: single_arm" in out and "middleware: thread" in out and out.rstrip().endswith("ok")

    bad = tmp_path / "bad.toml"
    bad.write_text('name = "b"\n[components.arm]\ndriver = "rio.fake_arm"\ndof = [')  # unclosed at the end
    assert main(["stations", "check", str(bad)]) == 1
    err = capsys.readouterr().err
    assert f"error: {bad}:4:8: TOML syntax error" in err


def test_doctor_finds_sdks_without_importing_them(tmp_path):
    marker = tmp_path / "imported"
    (tmp_path / "scservo_sdk.py").write_text(f"open({str(marker)!r}, 'w').close()\n")
    r = run_rio(["doctor", "--json"], tmp_path)
    assert r.returncode == 0, r.stderr
    data = json.loads(r.stdout)
    assert data["python"] == sys.version.split()[0]
    so100 = {r["module"]: r for r in data["requirements"]["rio-so100"]}
    assert so100["scservo_sdk"]["present"] is True and not marker.exists()
    assert so100["scservo_sdk"]["install"] == "pip install feetech-servo-sdk"
    assert {r["module"] for r in data["requirements"]["rio-core"]} >= {"zenoh", "copier", "av"}
    mws = {m["middleware"]: m for m in data["middlewares"]}
    assert mws["thread"]["ok"] is True and mws["thread"]["plugin"] == "rio-core"
    assert "rio-core" in [p["name"] for p in data["plugins"]]


def test_bench_middleware_passes_arguments_through(monkeypatch):
    seen = []
    fake = types.ModuleType("rio.benchmarks.middleware_latency")
    fake.main = lambda argv: seen.append(argv) or 3
    monkeypatch.setitem(sys.modules, "rio.benchmarks.middleware_latency", fake)
    assert main(["bench", "middleware", "--middleware", "thread", "-n", "100", "--help"]) == 3
    assert seen == [["--middleware", "thread", "-n", "100", "--help"]]


def test_plugin_subcommands_via_rio_cli_hook(registry, capsys):
    so100 = typer.Typer(help="SO-100 tools")

    @so100.command()
    def calibrate(port: str = "/dev/ttyACM0") -> None:
        print(f"calibrating on {port}")

    extra = typer.Typer()

    @extra.command()
    def hello() -> None:
        print("hello from a returned app")

    mounting = types.ModuleType("cli_mounting")
    mounting.rio_cli = hookimpl(lambda app: app.add_typer(so100, name="so100"))
    returning = types.ModuleType("cli_returning")
    returning.rio_cli = hookimpl(lambda: {"extra": extra})
    failing = types.ModuleType("cli_failing")

    def broken_cli(app):
        raise RuntimeError("no")

    failing.rio_cli = hookimpl(broken_cli)
    for name, mod in [("mounting", mounting), ("returning", returning), ("failing", failing)]:
        registry.register(mod, name=name)

    assert main(["so100", "calibrate", "--port", "/dev/ttyUSB3"]) == 0
    assert "calibrating on /dev/ttyUSB3" in capsys.readouterr().out
    assert main(["extra", "hello"]) == 0
    assert "hello from a returned app" in capsys.readouterr().out
    assert any(p.plugin == "failing" and "rio_cli raised RuntimeError" in p.message for p in registry.problems)


def test_usage_error_exit_code(capsys):
    assert main(["plugins", "lst"]) == 2
    assert "No such command" in capsys.readouterr().err


def test_stations_show_prints_the_file_and_copy_writes_it_naming_the_lines_to_edit(registry, tmp_path, capsys):
    """The documented first step for real hardware: `rio stations show NAME > mine.toml` or `rio stations copy`."""
    text = ('# the lab arm\nname = "lab-arm"\n[middleware]\nname = "thread"\n[components.arm]\n'
            'driver = "rio.fake_arm"\ndof = 6                 # EDIT: your arm\'s joints\n')
    packaged = tmp_path / "lab-arm.toml"
    packaged.write_text(text)
    mod = types.ModuleType("cli_copy_plugin")
    mod.rio_stations = hookimpl(lambda: [Spec("lab-arm", "station", str(packaged), "a lab arm")])
    registry.register(mod, name="cli-copy", dist="rio-lab")
    assert main(["stations", "show", "lab-arm"]) == 0
    assert capsys.readouterr().out == text
    mine = tmp_path / "mine.toml"
    assert main(["stations", "copy", "lab-arm", str(mine)]) == 0
    err = capsys.readouterr().err
    assert mine.read_text().endswith(text) and mine.read_text().startswith("# Copied from station 'lab-arm'")
    assert f"{mine}:8: dof = 6" in err and "EDIT" in err  # the header moved the file's lines down by one
    assert main(["stations", "copy", "lab-arm", str(mine)]) == 1  # never over a file without --force
    assert "--force" in capsys.readouterr().err
    assert main(["stations", "check", str(mine)]) == 0


def test_station_names_complete_in_the_shell(registry, tmp_path):
    from rio.cli.args import complete_station

    mod = types.ModuleType("cli_complete_plugin")
    mod.rio_stations = hookimpl(lambda: [Spec(n, "station", str(tmp_path / f"{n}.toml"), n)
                                         for n in ("lab-arm", "lab-bimanual", "desk")])
    registry.register(mod, name="cli-complete", dist="rio-lab")
    assert complete_station("lab-") == ["lab-arm", "lab-bimanual"] and complete_station("x") == []
    env = {**os.environ, "COMP_WORDS": "rio teleop sim-so", "COMP_CWORD": "2", "_RIO_COMPLETE": "complete_bash"}
    r = subprocess.run([sys.executable, "-m", "rio"], capture_output=True, text=True, env=env, timeout=60)
    assert "sim-so100" in r.stdout.split(), r.stdout  # through the shell hook, with the installed plugins


def test_help_shows_no_bool_type_on_flags_and_one_line_per_command():
    r = subprocess.run([sys.executable, "-m", "rio", "teleop", "--help"], capture_output=True, text=True,
                       env={**os.environ, "COLUMNS": "200"}, timeout=60)
    assert r.returncode == 0 and "--viz" in r.stdout and "<bool>" not in r.stdout, r.stdout
    assert "SECONDS" in r.stdout and "KEY=VALUE" in r.stdout
