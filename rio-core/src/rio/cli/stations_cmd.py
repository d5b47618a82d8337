"""`rio stations list` (packaged station files) and `rio stations check` (validate one fully)."""

from __future__ import annotations

from typing import Annotated

import typer

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
        print_json([{"name": s.name, "plugin": s.plugin, "target": s.target, "description": s.description}
                    for s in specs])
        return
    table("RIO stations", ("name", "plugin", "description", "file"),
          [(s.name, s.plugin, s.description, s.target) for s in sorted(specs, key=lambda s: s.name)])
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
