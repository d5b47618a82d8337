"""How much `pip install rio-core` and `pip install rio-core rio-<plugin>` put on disk, plugin by plugin.

Each row is a fresh venv in a temporary folder with rio-core and the plugin installed from this checkout
(the other rio-* projects a plugin or its extras ask for, too), everything else from the package index;
the size is the venv's site-packages (bytes of its files, bytecode included, as pip writes it), less the
venv's own pip (what `python -m venv` puts there besides pip, e.g. Python 3.11's setuptools, ~6 MB, is
counted in every row). The largest three top-level packages of each are named. From the repository root:

    python tools/install_sizes.py                     # rio-core, then core + every plugins/rio-*
    python tools/install_sizes.py rio-ufactory rio-ufactory[ik] rio-sim
    python tools/install_sizes.py --installer pip     # plain pip (slower; the default is uv when on PATH)

`uv pip install --compile-bytecode` and `pip install` install the same distributions; uv only does it faster
from its cache. Prints a Markdown table (the README's "Install size" section is one).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

ROOT = Path(__file__).resolve().parents[1]
#: The arm plugins whose kinematics is an extra: measured with it too, to show what the extra weighs.
IK_ROWS = ("rio-ufactory[ik]", "rio-ur[ik]", "rio-franka[ik]", "rio-kinova[ik]")
_REQ_NAME = re.compile(r"^\s*([A-Za-z0-9][A-Za-z0-9._-]*)\s*(\[([^\]]*)\])?")


def projects() -> dict[str, Path]:
    """{distribution name: project folder} of rio-core and every plugins/rio-*."""
    found = {"rio-core": ROOT / "rio-core"}
    for p in sorted((ROOT / "plugins").glob("rio-*")):
        if (p / "pyproject.toml").exists():
            found[p.name] = p
    return found


def local_needs(name: str, extras: set[str], known: dict[str, Path], seen: set[str] | None = None) -> set[str]:
    """The local projects `name[extras]` pulls in (itself included), through its dependencies and extras."""
    seen = set() if seen is None else seen
    key = f"{name}[{','.join(sorted(extras))}]"
    if key in seen:
        return set()
    seen.add(key)
    meta = tomllib.loads((known[name] / "pyproject.toml").read_text())["project"]
    reqs = list(meta.get("dependencies", []))
    for extra in extras:
        reqs += meta.get("optional-dependencies", {}).get(extra, [])
    out = {name}
    for req in reqs:
        m = _REQ_NAME.match(req)
        if m and m.group(1) in known:
            sub = {e.strip() for e in (m.group(3) or "").split(",") if e.strip()}
            out |= local_needs(m.group(1), sub, known, seen)
    return out


def site_packages(venv: Path) -> Path:
    return next((venv / "lib").glob("python3*/site-packages"))


def tree_bytes(path: Path) -> int:
    total = 0
    for dirpath, _, files in os.walk(path):
        for f in files:
            fp = os.path.join(dirpath, f)
            if not os.path.islink(fp):
                total += os.path.getsize(fp)
    return total


def largest(sp: Path, n: int = 3) -> list[tuple[str, int]]:
    """The `n` largest top-level entries of site-packages (a package, its .libs folder counted with it)."""
    sizes: dict[str, int] = {}
    for entry in sp.iterdir():
        if entry.name.endswith((".dist-info", ".pth")) or entry.name in ("pip", "_distutils_hack", "__pycache__"):
            continue
        base = re.sub(r"(\.libs|\.py)$", "", entry.name).lstrip("_")
        size = tree_bytes(entry) if entry.is_dir() else entry.stat().st_size
        sizes[base] = sizes.get(base, 0) + size
    return sorted(sizes.items(), key=lambda kv: -kv[1])[:n]


def measure(spec: str, known: dict[str, Path], workdir: Path, installer: str) -> tuple[float, list, float]:
    """(site-packages MB, largest entries, seconds) of a fresh venv with rio-core and `spec` installed."""
    m = _REQ_NAME.match(spec)
    if not m or m.group(1) not in known:
        raise SystemExit(f"unknown project '{spec}'; known: {', '.join(known)}")
    name, extras = m.group(1), {e.strip() for e in (m.group(3) or "").split(",") if e.strip()}
    venv = workdir / re.sub(r"\W", "_", spec)
    t0 = time.monotonic()
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    python = str(venv / "bin" / "python")
    paths = [str(known[p]) for p in sorted(local_needs(name, extras, known) | {"rio-core"}) if p != name]
    paths.append(str(known[name]) + (f"[{','.join(sorted(extras))}]" if extras else ""))
    if installer == "uv":
        # --no-sources: the workspace's `tool.uv.sources` would install rio-core editable (a .pth, not its files)
        cmd = ["uv", "pip", "install", "-q", "--no-sources", "--compile-bytecode", "--python", python, *paths]
    else:
        cmd = [python, "-m", "pip", "install", "-q", "--disable-pip-version-check", *paths]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError((done.stderr or done.stdout).strip().splitlines()[-1:] or ["install failed"])
    sp = site_packages(venv)
    pip_bytes = sum(tree_bytes(p) if p.is_dir() else p.stat().st_size for p in sp.glob("pip*"))
    mb = (tree_bytes(sp) - pip_bytes) / 1e6
    return mb, largest(sp), time.monotonic() - t0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("specs", nargs="*", help="projects to add to rio-core, e.g. rio-ufactory rio-ur[ik] "
                                             "(default: every plugins/rio-*, then the arm plugins with [ik])")
    ap.add_argument("--installer", choices=("uv", "pip"), default="uv" if shutil.which("uv") else "pip")
    args = ap.parse_args(argv)
    known = projects()
    specs = ["rio-core"] + (args.specs or [p for p in known if p != "rio-core"] + list(IK_ROWS))
    print("| install | site-packages (MB) | over rio-core (MB) | largest |\n|---|---:|---:|---|", flush=True)
    core_mb = None
    with tempfile.TemporaryDirectory(prefix="rio-sizes-") as tmp:
        for spec in specs:
            label = "rio-core" if spec == "rio-core" else f"rio-core + {spec}"
            try:
                mb, big, _ = measure(spec, known, Path(tmp), args.installer)
            except RuntimeError as e:
                print(f"| {label} | failed: {e.args[0][0][:80]} | | |", flush=True)
                continue
            if spec == "rio-core":
                core_mb = mb
            over = "" if core_mb is None or spec == "rio-core" else f"{mb - core_mb:.0f}"
            top = ", ".join(f"{n} {b / 1e6:.0f}" for n, b in big)
            print(f"| {label} | {mb:.0f} | {over} | {top} |", flush=True)
            shutil.rmtree(Path(tmp) / re.sub(r"\W", "_", spec), ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
