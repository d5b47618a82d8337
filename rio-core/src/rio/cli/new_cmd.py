"""`rio new plugin NAME --kind arm`: scaffold an installable, tested plugin distribution."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

app = typer.Typer(help="Create new things from templates.", no_args_is_help=True)


@app.command("plugin")
def plugin(
    name: Annotated[str, typer.Argument(help="Plugin name, lowercase (e.g. 'acme' -> rio-acme, driver 'acme.arm').")],
    kind: Annotated[str, typer.Option("--kind", "-k", help="arm | gripper | camera | teleop | policy")] = "arm",
    output: Annotated[Path, typer.Option("--output", "-o", help="Directory to create rio-NAME/ in.")] = Path("."),
    force: Annotated[bool, typer.Option("--force", help="Render into an existing, non-empty directory.")] = False,
) -> None:
    """Generate rio-NAME/: pyproject with the `rio` entry point, a driver node with its config model,
    an emulator, a station file, a test and a README."""
    from ..scaffold import new_plugin
    from .output import console

    dst = new_plugin(name, kind, output, force=force)
    console().print(f"created {dst}\nnext:\n  cd {dst}\n  pip install -e .   (or: uv pip install -e .)\n"
                    f"  rio plugins list\n  pytest", markup=False)
