"""`rio plugins install|uninstall`: the installer command builder, the CLI around it, and a real
editable install of a tiny plugin into a throwaway virtual environment (offline, from uv's cache)."""

from __future__ import annotations

import io
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import rio
from rio.cli import main
from rio.plugins import Registry
from rio.plugins import registry as plugins
from rio.plugins.install import (
    activate_new_paths,
    install_command,
    normalize,
    protected,
    pth_files,
    uninstall_command,
    uv_project_of,
)

PY = "/env/bin/python"
UV = "/usr/bin/uv"


# -- the command builder ----------------------------------------------------------------------------
def test_install_command_uv_and_pip():
    assert install_command(["rio-acme"], python=PY, uv_path=UV) == [UV, "pip", "install", "--python", PY, "rio-acme"]
    assert install_command(["rio-acme", "rio-foo>=1"], python=PY, uv_path=None) == \
        [PY, "-m", "pip", "install", "rio-acme", "rio-foo>=1"]


def test_install_command_editable_and_upgrade():
    assert install_command(["./a", "../b[test]"], editable=True, python=PY, uv_path=UV) == \
        [UV, "pip", "install", "--python", PY, "-e", "./a", "-e", "../b[test]"]
    assert install_command(["rio-acme"], upgrade=True, python=PY, uv_path=None) == \
        [PY, "-m", "pip", "install", "--upgrade", "rio-acme"]
    assert install_command(["./a"], editable=True, upgrade=True, python=PY, uv_path=UV) == \
        [UV, "pip", "install", "--python", PY, "--upgrade", "-e", "./a"]
    with pytest.raises(ValueError):
        install_command([], python=PY, uv_path=UV)


def test_uninstall_command_and_rio_core_is_protected():
    assert uninstall_command(["rio-acme"], python=PY, uv_path=UV) == \
        [UV, "pip", "uninstall", "--python", PY, "rio-acme"]
    assert uninstall_command(["rio-acme", "rio-b"], python=PY, uv_path=None) == \
        [PY, "-m", "pip", "uninstall", "-y", "rio-acme", "rio-b"]
    assert normalize("RIO_Core") == normalize("rio.core") == "rio-core"
    assert protected(["rio-acme", "RIO_core", "rio-sim"]) == ["RIO_core"]
    assert protected(["rio-acme"]) == []


def test_uv_project_of(tmp_path):
    assert uv_project_of(str(tmp_path / ".venv")) is None
    (tmp_path / "uv.lock").write_text("")
    assert uv_project_of(str(tmp_path / ".venv")) == str(tmp_path)


def test_activate_new_paths_reads_a_new_pth_file(tmp_path, monkeypatch):
    site_dir, src = tmp_path / "site", tmp_path / "src"
    site_dir.mkdir()
    src.mkdir()
    monkeypatch.setattr("rio.plugins.install._site_dirs", lambda: [str(site_dir)])
    monkeypatch.setattr(sys, "path", list(sys.path))
    before = pth_files()
    (site_dir / "_acme.pth").write_text(f"# comment\n{src}\nimport sys; sys._rio_pth_test = 1\n")
    activate_new_paths(before)
    assert str(src) in sys.path and sys.__dict__.pop("_rio_pth_test") == 1
    activate_new_paths(pth_files())  # an old file: its path is present already, its import line is not run
    assert sys.path.count(str(src)) == 1 and not hasattr(sys, "_rio_pth_test")


# -- the CLI, with the installer replaced ----------------------------------------------------------
@pytest.fixture
def fake_installer(monkeypatch):
    """Record installer commands instead of running them; plugins reload with rio-core only."""
    calls: list[list[str]] = []
    status = {"rc": 0}

    def call(cmd):
        calls.append(list(cmd))
        return status["rc"]

    monkeypatch.setattr(subprocess, "call", call)
    monkeypatch.setattr(shutil, "which", lambda name: UV if name == "uv" else None)
    monkeypatch.setenv("RIO_LOAD_PLUGINS", "")
    monkeypatch.setattr(plugins, "_REGISTRY", Registry(load_entry_points=False))
    monkeypatch.setenv("COLUMNS", "200")
    return calls, status


def test_cli_install_runs_the_installer_prints_it_and_lists_plugins(fake_installer, capsys):
    calls, _ = fake_installer
    assert main(["plugins", "install", "-e", "./rio-acme", "--upgrade"]) == 0
    assert calls == [[UV, "pip", "install", "--python", sys.executable, "--upgrade", "-e", "./rio-acme"]]
    out, err = capsys.readouterr()
    assert f"$ {UV} pip install --python {sys.executable} --upgrade -e ./rio-acme" in err
    assert "RIO plugins" in out and "rio-core" in out  # the registry was reloaded and listed


def test_cli_install_failure_is_a_nonzero_exit(fake_installer, capsys):
    calls, status = fake_installer
    status["rc"] = 2
    assert main(["plugins", "install", "rio-nonexistent"]) == 2
    assert "exit status 2" in capsys.readouterr().err
    assert len(calls) == 1


def test_cli_install_without_uv_uses_pip(fake_installer, monkeypatch):
    calls, _ = fake_installer
    monkeypatch.setattr(shutil, "which", lambda name: None)
    monkeypatch.setattr("importlib.util.find_spec", lambda name, *a: object() if name == "pip" else None)
    assert main(["plugins", "install", "rio-acme"]) == 0
    assert calls == [[sys.executable, "-m", "pip", "install", "rio-acme"]]


def test_cli_uninstall_refuses_rio_core(fake_installer, capsys):
    calls, _ = fake_installer
    assert main(["plugins", "uninstall", "-y", "rio-acme", "RIO_Core"]) == 1
    assert calls == []
    assert "refusing to uninstall RIO_Core" in capsys.readouterr().err


def test_cli_uninstall_asks_unless_yes(fake_installer, monkeypatch):
    calls, _ = fake_installer
    monkeypatch.setattr(sys, "stdin", io.StringIO("n\n"))
    assert main(["plugins", "uninstall", "rio-acme"]) == 1
    assert calls == []
    monkeypatch.setattr(sys, "stdin", io.StringIO("y\n"))
    assert main(["plugins", "uninstall", "rio-acme"]) == 0
    assert main(["plugins", "uninstall", "--yes", "rio-b"]) == 0
    assert calls == [[UV, "pip", "uninstall", "--python", sys.executable, "rio-acme"],
                     [UV, "pip", "uninstall", "--python", sys.executable, "rio-b"]]


# -- end to end: a real install into a throwaway environment ---------------------------------------
PLUGIN_PYPROJECT = """\
[project]
name = "rio-tinytest"
version = "0.3.0"
dependencies = ["rio-core"]

[project.entry-points.rio]
tinytest = "rio_tinytest.plugin"

[build-system]
requires = ["hatchling>=1.24"]
build-backend = "hatchling.build"

[tool.hatch.build.targets.wheel]
packages = ["src/rio_tinytest"]
"""
PLUGIN_MODULE = """\
from rio.plugins.hookspecs import hookimpl
from rio.plugins.specs import Spec


@hookimpl
def rio_drivers():
    return [Spec("tinytest.arm", "arm", "rio_tinytest.driver:Arm", "a test arm")]
"""
OFFLINE_HINT = "network was disabled"


def _pinned_requirements(dist: str) -> list[str]:
    """`name==version` of every distribution `dist` needs, as installed in this environment."""
    from importlib.metadata import distribution

    from packaging.requirements import Requirement

    found: dict[str, str] = {}
    todo: list[tuple[str, frozenset[str]]] = [(dist, frozenset())]
    while todo:
        name, extras = todo.pop()
        d = distribution(name)
        found[normalize(name)] = d.version
        for line in d.requires or []:
            req = Requirement(line)
            if req.marker is not None and not any(req.marker.evaluate({"extra": e}) for e in extras | {""}):
                continue
            if normalize(req.name) not in found:
                todo.append((req.name, frozenset(req.extras)))
    return [f"{n}=={v}" for n, v in sorted(found.items()) if n != normalize(dist)]


def _run(cmd, env, cwd):
    # cwd outside any project: uv reads no project's [tool.uv] settings (this repository compiles bytecode)
    return subprocess.run([str(c) for c in cmd], capture_output=True, text=True, env=env, cwd=cwd, timeout=180)


@pytest.fixture(scope="module")
def venv(tmp_path_factory):
    """A fresh virtual environment holding rio-core (editable, from this checkout) and its dependencies,
    installed with uv from its cache without network; the environment running the tests is untouched."""
    uv = shutil.which("uv")
    if uv is None:
        pytest.skip("uv is not on PATH: the end-to-end install test creates its environment with uv")
    rio_core_dir = Path(rio.__file__).resolve().parents[2]
    if not (rio_core_dir / "pyproject.toml").is_file():
        pytest.skip(f"rio is not installed from a source checkout ({rio.__file__})")
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "PYTHONPATH", "RIO_LOAD_PLUGINS")}
    env.update(UV_OFFLINE="1", PATH=os.pathsep.join([str(Path(uv).parent), env.get("PATH", "")]),
               COLUMNS="200", UV_NO_PROGRESS="1")
    root = tmp_path_factory.mktemp("install_e2e")
    r = _run([uv, "venv", "--python", sys.executable, root / "venv"], env, root)
    if r.returncode != 0:
        pytest.skip(f"uv venv failed: {r.stderr.strip()[-500:]}")
    python = root / "venv" / "bin" / "python"
    # --no-deps with exact pins: offline, uv can install cached wheels, not resolve afresh; compiled, as
    # each `python -m rio` below would otherwise compile numpy, pydantic and rich where PYTHONDONTWRITEBYTECODE
    r = _run([uv, "pip", "install", "--python", python, "--no-deps", "--compile-bytecode",
              *_pinned_requirements("rio-core"), "-e", rio_core_dir], env, root)
    if r.returncode != 0 and OFFLINE_HINT in r.stderr:
        pytest.skip(f"rio-core's dependencies or build backend are not in uv's cache: {r.stderr.strip()[-500:]}")
    assert r.returncode == 0, r.stderr
    return python, env, root


def _listed(python, env, cwd) -> dict[str, dict]:
    r = _run([python, "-m", "rio", "plugins", "list", "--json"], env, cwd)
    assert r.returncode == 0, r.stderr
    return {p["distribution"]: p for p in json.loads(r.stdout)["plugins"]}


@pytest.mark.slow
def test_install_and_uninstall_a_local_plugin_for_real(venv):
    python, env, root = venv
    plugin = root / "rio-tinytest"
    (plugin / "src" / "rio_tinytest").mkdir(parents=True)
    (plugin / "pyproject.toml").write_text(PLUGIN_PYPROJECT)
    (plugin / "src" / "rio_tinytest" / "__init__.py").write_text("")
    (plugin / "src" / "rio_tinytest" / "plugin.py").write_text(PLUGIN_MODULE)
    assert "rio-tinytest" not in _listed(python, env, root)

    r = _run([python, "-m", "rio", "plugins", "install", "-e", plugin], env, root)
    if r.returncode != 0 and OFFLINE_HINT in r.stderr:
        pytest.skip(f"the build backend (hatchling) is not in uv's cache: {r.stderr.strip()[-500:]}")
    assert r.returncode == 0, r.stderr
    assert f"pip install --python {python} -e {plugin}" in r.stderr  # the command is printed
    # listed by the same process right after installing: the editable .pth was picked up
    assert "rio-tinytest" in r.stdout and "tinytest.arm" in r.stdout, r.stdout + r.stderr
    listed = _listed(python, env, root)
    assert listed["rio-tinytest"]["version"] == "0.3.0"
    assert listed["rio-tinytest"]["provides"] == {"arm": ["tinytest.arm"]}

    r = _run([python, "-m", "rio", "plugins", "uninstall", "rio-core"], env, root)
    assert r.returncode == 1 and "refusing to uninstall rio-core" in r.stderr
    r = _run([python, "-m", "rio", "plugins", "uninstall", "-y", "rio-tinytest"], env, root)
    assert r.returncode == 0, r.stderr
    assert "rio-tinytest" not in r.stdout
    assert set(_listed(python, env, root)) == {"rio-core"}
