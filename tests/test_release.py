"""Release readiness: every distribution builds, passes `twine check --strict`, ships the MIT LICENSE and
declares the version policy (a RIO distribution that depends on rio-core, or on another RIO distribution,
requires the same minor series: `>=0.1,<0.2` while rio-core is 0.1.x); then the path a user takes,
`pip install rio-core rio-so100` into a fresh virtual environment (plain venv + pip, not uv), gives a
working `rio plugins list`, `rio doctor`, `rio-robot` and `python -m rio`.

Needs `uv` (to build) and the package index (build backend, the wheels' dependencies): skipped, saying
which, without them. Build outputs go to pytest's temporary directory; pip's own cache is reused."""

from __future__ import annotations

import json
import os
import re
import shutil
import socket
import subprocess
import sys
import tarfile
import venv
import zipfile
from email.parser import Parser
from pathlib import Path
from urllib.parse import urlparse

import pytest

pytestmark = pytest.mark.slow  # every test here runs for tens of seconds (a module fixture builds, installs or records)

try:
    import tomllib
except ImportError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
DIST_DIRS = [ROOT / "rio-core", *sorted(p.parent for p in ROOT.glob("plugins/*/pyproject.toml"))]
RIO_DISTS = {"rio-core", "rio-sim", "rio-robotiq"}  # the RIO distributions others depend on


def _norm(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _project(path: Path) -> dict:
    return tomllib.loads((path / "pyproject.toml").read_text())["project"]


def _uv() -> str | None:
    return shutil.which("uv") or next((str(p) for p in [Path.home() / ".local/bin/uv"] if p.exists()), None)


def _index_reachable() -> str | None:
    """None when pip's package index answers, else why not."""
    url = os.environ.get("PIP_INDEX_URL") or os.environ.get("UV_INDEX_URL") or "https://pypi.org/simple"
    u = urlparse(url)
    if u.scheme == "file":
        return None
    try:
        socket.create_connection((u.hostname, u.port or (443 if u.scheme == "https" else 80)), timeout=5).close()
    except OSError as e:
        return f"no network: the package index {u.hostname} is unreachable ({e})"
    return None


CORE_VERSION = _project(ROOT / "rio-core")["version"]
MAJOR, MINOR = (int(x) for x in CORE_VERSION.split(".")[:2])
BOUND = f">={MAJOR}.{MINOR},<{MAJOR}.{MINOR + 1}"


@pytest.fixture(scope="module")
def dists(tmp_path_factory) -> Path:
    uv = _uv()
    if uv is None:
        pytest.skip("uv is not installed: it builds the distributions (pip install uv)")
    why = _index_reachable()
    if why:
        pytest.skip(why)
    out = tmp_path_factory.mktemp("rel-dist")
    env = {k: v for k, v in os.environ.items() if k not in {"VIRTUAL_ENV", "UV_PROJECT_ENVIRONMENT"}}
    # the workspace members, then the LeRobot bridge (excluded from the workspace, released all the same)
    for args in (["--all-packages"], [str(ROOT / "plugins/lerobot-robot-rio")]):
        r = subprocess.run([uv, "build", "--quiet", *args, "--out-dir", str(out)], cwd=ROOT, env=env,
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, f"uv build {' '.join(args)} failed:\n{r.stdout}\n{r.stderr}"
    return out


def _wheel(dists: Path, name: str) -> Path:
    [whl] = dists.glob(f"{name.replace('-', '_')}-*.whl")
    return whl


def test_every_distribution_builds_a_wheel_and_an_sdist(dists):
    for d in DIST_DIRS:
        stem = _project(d)["name"].replace("-", "_")
        assert len(list(dists.glob(f"{stem}-*.whl"))) == 1, d
        assert len(list(dists.glob(f"{stem}-*.tar.gz"))) == 1, d


def test_twine_check_strict(dists):
    pytest.importorskip("twine", reason="twine is in the dev dependency group (uv sync)")
    files = sorted(str(p) for p in dists.iterdir() if p.suffix in {".whl", ".gz"})
    r = subprocess.run([sys.executable, "-m", "twine", "check", "--strict", *files], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.count("PASSED") == len(files), r.stdout


def test_wheels_ship_the_license_metadata_and_the_version_policy(dists):
    for d in DIST_DIRS:
        project = _project(d)
        whl = _wheel(dists, project["name"])
        with zipfile.ZipFile(whl) as z:
            names = z.namelist()
            [meta_name] = [n for n in names if n.endswith(".dist-info/METADATA")]
            meta = Parser().parsestr(z.read(meta_name).decode())
            assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names), whl.name
            assert "MIT License" in z.read(next(n for n in names if n.endswith("licenses/LICENSE"))).decode()
        assert meta["License-Expression"] == "MIT" and meta["Author"] == "RIO contributors", whl.name
        urls = dict(u.split(", ", 1) for u in meta.get_all("Project-URL"))
        assert {"Homepage", "Documentation", "Repository", "Issues"} <= set(urls), whl.name
        classifiers = meta.get_all("Classifier")
        assert "Development Status :: 3 - Alpha" in classifiers, whl.name
        assert {f"Programming Language :: Python :: 3.{m}" for m in range(10, 14)} <= set(classifiers), whl.name
        assert meta["Keywords"] and len(meta.get_payload()) > 400, f"{whl.name}: keywords, a real README"
        from packaging.requirements import Requirement

        rio_reqs = [Requirement(r) for r in meta.get_all("Requires-Dist") or []]
        rio_reqs = [r for r in rio_reqs if _norm(r.name) in RIO_DISTS and _norm(r.name) != _norm(project["name"])]
        if project["name"] != "rio-core":
            assert any(_norm(r.name) == "rio-core" for r in rio_reqs), f"{whl.name} does not depend on rio-core"
        for r in rio_reqs:
            assert r.specifier == type(r.specifier)(BOUND), f"{whl.name}: {r} (policy: {r.name}{BOUND})"
        with tarfile.open(next(dists.glob(f"{whl.name.split('-')[0]}-*.tar.gz"))) as t:
            assert any(n.endswith("/LICENSE") for n in t.getnames()), f"{whl.name}: sdist without LICENSE"

    with zipfile.ZipFile(_wheel(dists, "rio-core")) as z:
        scripts = z.read(next(n for n in z.namelist() if n.endswith("entry_points.txt"))).decode()
    assert "rio = rio.cli:main" in scripts and "rio-robot = rio.cli:main" in scripts


def test_pip_install_core_and_so100_in_a_fresh_venv(dists, tmp_path):
    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=True)
    bin_dir = env_dir / ("Scripts" if os.name == "nt" else "bin")
    env = {k: v for k, v in os.environ.items()
           if k not in {"PYTHONPATH", "VIRTUAL_ENV", "RIO_LOAD_PLUGINS", "PYTHONHOME"}}
    env.update(COLUMNS="200", PIP_DISABLE_PIP_VERSION_CHECK="1")
    # the two wheels from the files just built; their other dependencies from the index (pip's cache reused)
    r = subprocess.run([str(bin_dir / "python"), "-m", "pip", "install", "--quiet",
                        str(_wheel(dists, "rio-core")), str(_wheel(dists, "rio-so100"))],
                       capture_output=True, text=True, env=env, timeout=240)
    if r.returncode != 0 and _index_reachable():
        pytest.skip(_index_reachable())
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]

    def rio(*args: str, exe: str = "rio") -> subprocess.CompletedProcess:
        return subprocess.run([str(bin_dir / exe), *args], capture_output=True, text=True, env=env,
                              cwd=tmp_path, timeout=120)

    r = rio("plugins", "list", "--json")
    assert r.returncode == 0, r.stderr
    found = {p["distribution"] for p in json.loads(r.stdout)["plugins"]}
    assert {"rio-core", "rio-so100"} <= found, found
    r = rio("doctor", "--json")
    assert r.returncode == 0, r.stderr  # `rio doctor` reports; it exits 0 whatever is missing
    data = json.loads(r.stdout)
    assert {p["name"] for p in data["plugins"]} >= {"rio-core", "rio-so100"} and data["problems"] == []
    assert data["rio_script_clashes"] == []
    for exe, args in (("rio-robot", ["--version"]), ("python", ["-m", "rio", "--version"])):
        r = rio(*args, exe=exe)
        assert r.returncode == 0 and r.stdout.strip() == f"rio {CORE_VERSION}", (exe, r.stdout, r.stderr)
    # a core-only install names the extra to add instead of failing with a traceback
    r = rio("new", "plugin", "myarm", "--kind", "arm")
    assert r.returncode != 0 and "pip install 'rio-core[new]'" in r.stdout + r.stderr, r.stdout + r.stderr
    assert "Traceback" not in r.stderr
