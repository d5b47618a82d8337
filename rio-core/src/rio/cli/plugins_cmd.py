"""`rio plugins list`: each plugin, its version and what it provides, plus any plugin problems."""

from __future__ import annotations

from typing import Annotated

import typer

app = typer.Typer(help="Installed RIO plugins.", no_args_is_help=True)


@app.command("list")
def list_plugins(as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False) -> None:
    """List plugins (the `rio` entry-point group; RIO_LOAD_PLUGINS=a,b loads only those)."""
    from ..plugins import get_registry
    from .output import print_json, table, warn_problems

    reg = get_registry()
    reg.all_specs()  # fills each plugin's `provides` and collects problems
    plugins = list(reg.plugins.values())
    if as_json:
        print_json({
            "plugins": [{"name": p.name, "distribution": p.dist, "version": p.version, "module": p.module,
                         "provides": p.provides} for p in plugins],
            "problems": [{"plugin": x.plugin, "message": x.message} for x in reg.problems],
        })
        return
    rows = []
    for p in plugins:
        provides = "; ".join(f"{kind}: {', '.join(names)}" for kind, names in sorted(p.provides.items())) or "-"
        rows.append((p.dist, p.version, provides))
    table("RIO plugins", ("plugin", "version", "provides"), rows)
    warn_problems(reg)
