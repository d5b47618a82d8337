"""`rio cameras list [--json]`: the cameras connected to this machine, from every camera plugin."""

from __future__ import annotations

from typing import Annotated

import typer

app = typer.Typer(help="Cameras connected to this machine.", no_args_is_help=True)


@app.command("list")
def list_cameras(as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False) -> None:
    """Each connected camera: the driver that opens it, the value that selects it (serial, device path),
    model, firmware and modes. Plugins whose SDK could not list are named below the table."""
    from rio.cli.output import console, print_json, table
    from rio.plugins.cameras import list_cameras as find

    devices, problems = find()
    if as_json:
        print_json({"cameras": [d.as_dict() for d in devices], "problems": problems})
        return
    if devices:
        rows = [(d.driver, f"{d.select_field} = {d.id}", d.model, d.firmware,
                 ", ".join(d.modes[:4]) + (f" (+{len(d.modes) - 4})" if len(d.modes) > 4 else ""))
                for d in devices]
        table("Connected cameras", ("driver", "select with", "model", "firmware", "modes"), rows)
    else:
        console().print("No camera found by the installed camera plugins.", markup=False)
    for d in devices:
        if d.note:
            console().print(f"{d.driver} {d.select_field} = {d.id}: {d.note}", markup=False)
    for line in problems:
        console().print(f"could not list: {line}", markup=False)
