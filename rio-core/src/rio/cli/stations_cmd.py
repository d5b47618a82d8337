"""`rio stations list` (packaged station files), `check` (validate one fully), `show` and `copy` (start yours
from one)."""

from __future__ import annotations

from typing import Annotated

import typer

from rio.cli.args import not_empty
from rio.cli.run_cmd import MiddlewareOption, StationArgument

app = typer.Typer(help="Station files.", no_args_is_help=True)


@app.command("list")
def list_stations(as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False) -> None:
    """List the station files that plugins ship (use the name wherever a station path is accepted)."""
    from rio.cli.output import print_json, table, warn_problems
    from rio.plugins import get_registry

    reg = get_registry()
    specs = reg.specs("rio_stations")
    if as_json:
        print_json([{"name": s.name, "plugin": s.plugin, "target": s.target, "description": s.description,
                     "formerly": list(s.formerly)} for s in specs])
        return
    table("RIO stations", ("name", "plugin", "description", "file"),
          [(s.name, s.plugin, s.description + (f" (formerly {', '.join(s.formerly)})" if s.formerly else ""),
            s.target) for s in sorted(specs, key=lambda s: s.name)])
    warn_problems(reg)


@app.command("check")
def check(
    station: StationArgument,
    middleware: MiddlewareOption = None,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """Validate a station completely (drivers, their fields, middleware options, embodiment, the network
    checks of a start: nodes placed on other machines) and show what it contains; imports the drivers' code
    but starts nothing."""
    from rio.cli.output import console, print_json, table
    from rio.station import load_station
    from rio.station.build import check_network, load_node_class, resolve_embodiment, resolve_middleware

    st = load_station(station)
    mw = resolve_middleware(st, middleware)
    check_network(st, mw)
    emb, options = resolve_embodiment(st)
    for role in st.components:
        load_node_class(st, role)
    if as_json:
        from pydantic_core import to_jsonable_python

        print_json(to_jsonable_python({
            "name": st.name, "source": str(st.source), "rate_hz": st.rate_hz,
            "middleware": {"name": mw.name, "config": mw.config.model_dump()},
            "embodiment": {"name": emb.name, "options": options.model_dump()} if emb else None,
            "components": [{"role": role, "kind": c.kind, "driver": c.driver, "plugin": c.spec.plugin,
                            "config": c.kwargs()} for role, c in st.components.items()],
            "ok": True}, fallback=str))
        return
    rows = [(role, c.kind, c.driver, c.spec.plugin,
             ", ".join(f"{k}={v!r}" for k, v in c.kwargs().items())) for role, c in st.components.items()]
    table(f"station '{st.name}' ({st.source})", ("role", "kind", "driver", "plugin", "config"), rows)
    emb_text = f"{emb.name} ({options.model_dump()})" if emb else "none (no arm or humanoid role)"
    console().print(f"middleware: {mw.name} {mw.config.model_dump()}\ncontrol rate: {st.rate_hz:g} Hz\n"
                    f"embodiment: {emb_text}\nok", markup=False)


@app.command("show")
def show(station: StationArgument) -> None:
    """Print a station's file as it is (a packaged station's TOML, with its comments): the start of your own
    (`rio stations copy` writes it to a file)."""
    from rio.station.load import read_station_text

    text, _source = read_station_text(station)
    typer.echo(text, nl=not text.endswith("\n"))


def _toml_path(value: str) -> str:
    not_empty(value)
    if not value.endswith(".toml"):
        raise typer.BadParameter(f"{value}: a station file ends in .toml")
    return value


@app.command("copy")
def copy(
    station: StationArgument,
    path: Annotated[str, typer.Argument(callback=_toml_path, help="The .toml file to write.", show_default=False)],
    force: Annotated[bool, typer.Option("--force", help="Replace the file if it exists.")] = False,
) -> None:
    """Write a station's file to PATH to make it yours, and list the lines its author marked to change for
    your hardware (EDIT: addresses, serial ports, camera serials)."""
    from pathlib import Path

    from rio.errors import RioError
    from rio.station.load import read_station_text

    text, source = read_station_text(station)
    out = Path(path)
    if out.exists() and not force:
        raise RioError(f"{out} exists; pass --force to replace it")
    edits = [(n, line.strip()) for n, line in enumerate(text.splitlines(), start=2) if "EDIT" in line]
    head = f"# Copied from station '{station}' ({source}) by `rio stations copy`.\n"
    try:
        out.write_text(head + text, encoding="utf-8")
    except OSError as e:
        raise RioError(f"cannot write {out}: {e.strerror or e}") from None
    typer.echo(f"wrote {out}", err=True)
    if edits:
        typer.echo("change these lines for your hardware before the first run:", err=True)
        for n, line in edits:
            typer.echo(f"  {out}:{n}: {line}", err=True)
    typer.echo(f"then: rio stations check {out}", err=True)
