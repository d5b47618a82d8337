"""`rio doctor`: what this machine can run. What each plugin needs comes from the plugins themselves
(the `rio_requirements` hook), so the list grows with what is installed instead of with core's guesses.
Modules are located with `importlib.util.find_spec` only, so a broken or slow vendor SDK is never
imported just to be listed; a plugin's system check that fails is shown, never raised."""

from __future__ import annotations

import platform
import re
import sys
from typing import Annotated, Any

import typer

from rio.machine import host
from rio.plugins.requirements import evaluate, module_present

# middleware name -> (import name or None, install command)
MIDDLEWARE_DEPS = {
    "thread": (None, ""),
    "shm": (None, ""),
    "zmq": ("zmq", "pip install pyzmq"),
    "zenoh": ("zenoh", "pip install 'rio-core[zenoh]'"),
    "portal": (None, ""),  # portal's wire format, spoken by our own client and server
}


def _middleware_rows(reg: Any) -> list[dict[str, Any]]:
    rows = []
    for spec in reg.specs("rio_middlewares"):
        module, install = MIDDLEWARE_DEPS.get(spec.name, (None, ""))
        dep_ok = module is None or module_present(module)
        # the implementing module itself (find_spec imports only its parent packages)
        impl_ok = module_present(spec.target.partition(":")[0])
        why = install if not dep_ok else ("" if impl_ok else f"{spec.target} not found (plugin {spec.plugin})")
        if spec.name == "shm" and not host.has_shared_memory():
            dep_ok, why = False, "no POSIX shared memory here: use zmq or zenoh, or WSL2 (docs/platforms.md)"
        rows.append({"middleware": spec.name, "plugin": spec.plugin, "dependency": module or "-",
                     "ok": dep_ok and impl_ok, "install": why})
    return rows


def rio_script_clashes() -> list[str]:
    """Other installed distributions that also provide a `rio` console script (rasterio does, for one):
    whichever was installed last owns `rio` on PATH. `rio-robot` and `python -m rio` always reach RIO."""
    from importlib.metadata import entry_points

    others = set()
    for ep in entry_points(group="console_scripts", name="rio"):
        dist = getattr(ep, "dist", None)
        name = dist.metadata["Name"] if dist is not None else None
        if name and re.sub(r"[-_.]+", "-", name).lower() != "rio-core":
            others.add(f"{name} ({ep.value})")
    return sorted(others)


def _clash_text(clashes: list[str]) -> str:
    return (f"another installed package also provides a `rio` command: {', '.join(clashes)}; the `rio` on PATH "
            "may not be RIO's: use `rio-robot` or `python -m rio` (same command), or uninstall the other package")


def _check_text(row: dict[str, Any]) -> str:
    if row["check"] is None:
        return "-"
    if not row["checked"]:
        return "not run (module missing)"
    return row["problem"] or "ok"


def doctor(as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False) -> None:
    """Python version, plugins found, what each plugin needs and whether this machine has it."""
    from rich.markup import escape

    from rio import __version__
    from rio.cli.output import console, print_json, table, warn, warn_problems
    from rio.plugins import get_registry

    reg = get_registry()
    reg.all_specs()
    mw_rows = _middleware_rows(reg)
    needs = {dist: [evaluate(r).as_dict() for r in reqs] for dist, reqs in reg.requirements().items()}
    info = {"python": sys.version.split()[0], "platform": platform.platform(), "rio": __version__,
            "executable": sys.executable, "host": host.describe()}
    clashes = rio_script_clashes()
    if as_json:
        print_json({**info, "plugins": [{"name": p.dist, "version": p.version} for p in reg.plugins.values()],
                    "problems": [str(p) for p in reg.problems], "middlewares": mw_rows, "requirements": needs,
                    "rio_script_clashes": clashes})
        return
    out = console()
    out.print(f"rio {info['rio']} on Python {info['python']} ({info['platform']})\n{info['executable']}\n"
              f"host: {info['host']} (docs/platforms.md)", markup=False)
    table("plugins", ("plugin", "version"), [(p.dist, p.version) for p in reg.plugins.values()])
    from rich.text import Text

    mark = {True: Text("yes", style="green"), False: Text("no", style="red"), None: "-"}
    table("middlewares", ("middleware", "needs", "present", "to install"),
          [(r["middleware"], r["dependency"], mark[r["ok"]], r["install"]) for r in mw_rows])
    for dist, rows in needs.items():
        table(f"{dist} needs", ("module", "for", "present", "check", "to install"),
              [(r["module"] or "-", r["purpose"], mark[r["present"]],
                Text(_check_text(r), style="red") if r["problem"] else _check_text(r),
                "" if r["present"] is not False else r["install"]) for r in rows])
    warn_problems(reg)
    if clashes:
        warn(escape(_clash_text(clashes)))
