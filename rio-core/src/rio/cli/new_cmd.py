"""`rio new plugin NAME --kind KIND` scaffolds an installable, tested plugin; `rio new driver NAME --kind
KIND`, run in a plugin's folder, adds another driver (of any kind) to it."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from rio.cli.args import existing_dir, not_empty, output_dir

app = typer.Typer(help="Create new things from templates.", no_args_is_help=True)

_KINDS = "arm | gripper | camera | teleop | policy | sensor"


@app.command("plugin")
def plugin(
    name: Annotated[str, typer.Argument(
        callback=not_empty, help="Plugin name, lowercase (e.g. 'acme' -> rio-acme, driver 'acme.arm').")],
    kind: Annotated[str, typer.Option("--kind", "-k", callback=not_empty, help=_KINDS)] = "arm",
    output: Annotated[str, typer.Option("--output", "-o", callback=output_dir,
                                        help="Directory to create rio-NAME/ in.")] = ".",
    force: Annotated[bool, typer.Option("--force", help="Render into an existing, non-empty directory.")] = False,
) -> None:
    """Generate rio-NAME/: pyproject with the `rio` entry point, a driver of KIND in the kind's contract,
    an emulator, a demo station, tests and a README."""
    from rio.plugins.scaffold import new_plugin

    dst = new_plugin(name, kind, Path(output), force=force)
    typer.echo(f"created {dst}\nnext, install it into this environment and test it:\n"
               f"  rio plugins install -e {dst}     (in a RIO checkout: uv run rio plugins install -e {dst})\n"
               f"  rio plugins list\n  pytest {dst / 'tests'}\nthen see {dst / 'README.md'} (\"Try it\")")


@app.command("driver")
def driver(
    name: Annotated[str, typer.Argument(
        callback=not_empty, help="Driver name, a Python module name (e.g. 'wrist_camera' -> "
                                 "'<plugin>.wrist_camera' in src/<package>/wrist_camera.py).")],
    kind: Annotated[str, typer.Option("--kind", "-k", callback=not_empty, help=_KINDS)] = "arm",
    plugin_dir: Annotated[str, typer.Option("--plugin", "-p", callback=existing_dir,
                                            help="The plugin's folder (default: the one containing the current "
                                                 "directory).")] = ".",
    register: Annotated[bool, typer.Option("--register/--no-register",
                                           help="Add the driver's specs to the plugin's plugin.py.")] = True,
) -> None:
    """Add a driver of KIND to an existing plugin: its module, an emulator, a demo station and a test;
    then register it in plugin.py (or print the lines to add when that file is not in a shape that can
    be edited safely)."""
    from rio.plugins.scaffold import new_driver

    out = new_driver(name, kind, Path(plugin_dir), register=register)
    root = out.plugin.root
    files = "\n".join(f"  {f.relative_to(root)}" for f in out.files)
    typer.echo(f"added {out.values['driver']} to {out.plugin.dist} ({root}):\n{files}\n{out.instructions()}\n"
               f"next: pytest {root / 'tests' / (out.values['test_module'] + '.py')}\n"
               f"      rio stations check {out.values['station']}   (an editable install picks the new driver up; "
               "reinstall a regular one)")
