"""`rio serve STATION --machine NAME`: serve the nodes a station places on this machine, until stopped.

The other half of a station spread over machines (`[machines]` in the station file): run this on the
robot's machine, then the workflow (`rio teleop STATION`, `rio deploy ...`) on the machine with the
control loop; it connects to these nodes at their fixed addresses. The nodes keep running when the
loop side stops, crashes or loses the link, so a later run connects again without restarting them;
an arm whose commands stop holds by its own watchdog.

It ends like every workflow (`rio.cli.exit_status`): with a summary, what went wrong first (a node that
stopped with an error ends serving at once, 4; a fault or a lost link, 5; a safety stop, 6: those are
watched in the commanded nodes' samples while serving goes on), and 128 + N for the signal that stopped
it when nothing went wrong."""

from __future__ import annotations

from typing import Annotated

import typer

from rio.cli.args import not_empty
from rio.cli.run_cmd import MiddlewareOption, StationArgument


def serve(
    station: StationArgument,
    machine: Annotated[str | None, typer.Option(
        "--machine", callback=not_empty,
        help="This machine's name in the station's [machines] (serves the nodes placed there).")] = None,
    nodes: Annotated[str | None, typer.Option(
        "--nodes", callback=not_empty,
        help="Comma-separated roles to serve (instead of --machine: the machine that holds them).")] = None,
    middleware: MiddlewareOption = None,
) -> None:
    """Serve this machine's nodes of a station spread over several machines (Ctrl-C stops them)."""
    import contextlib

    from rio import clock
    from rio.cli.exit_status import exit_code
    from rio.errors import ConfigError, NodeDiedError
    from rio.interfaces.commanded import CommandedNode
    from rio.loop.health import NodeHealth
    from rio.loop.signals import StopSignals
    from rio.loop.summary import ERROR, RunSummary
    from rio.runtime.manager import ServerManager
    from rio.station.build import make_station
    from rio.station.load import load_station

    with StopSignals() as stop:
        st = load_station(station)
        machine = _which_machine(st, machine, nodes)
        servers, clients, _env = make_station(st, middleware=middleware, machine=machine)
        if not servers:
            raise ConfigError(f"machine '{machine}' serves no node of station '{st.name}'")
        sec = st.machines[machine]
        typer.echo(f"starting {', '.join(servers)} of station '{st.name}' as machine '{machine}' "
                   f"({sec.address}, ports from {sec.port}) ...")
        summary = RunSummary("serve", st.name, reason="serving")
        with ServerManager(servers, station=st.name) as manager, contextlib.ExitStack() as watched:
            commanded = {r: watched.enter_context(clients[r]()) for r in servers
                         if issubclass(clients[r].cls, CommandedNode)}
            health = NodeHealth(commanded, summary)
            t0 = clock.now()
            typer.echo(f"serving {', '.join(servers)}; stop with Ctrl-C")
            while not stop.received:
                ended = manager.ended()
                if ended:
                    for name in ended:
                        role = name.split(" ", 1)[0]
                        summary.add_event(ERROR, role, manager.cause(role) or name, clock.now() - t0)
                    summary.reason = f"node {', '.join(ended)} stopped; the others were stopped"
                    break
                with contextlib.suppress(NodeDiedError):  # ended() says which and why, next time round
                    health.check(clock.now() - t0)
                clock.precise_wait(clock.now() + 0.2)
            summary.seconds = clock.now() - t0
        if stop.received:
            summary.reason, summary.signal = f"stopped by {stop.received}", stop.received
        typer.echo(summary.format())
    raise typer.Exit(exit_code(summary))


def _which_machine(st, machine: str | None, nodes: str | None) -> str:  # noqa: ANN001 - a Station
    from rio.errors import ConfigError

    if not st.machines:
        raise ConfigError(f"{st.source} places no node on another machine: add a [machines.<name>] section "
                          "(docs/stations.md, 'Several machines')")
    if machine is not None:
        if nodes is not None:
            raise typer.BadParameter("give --machine or --nodes, not both", param_hint="--nodes")
        return machine
    if nodes is None:
        raise typer.BadParameter(f"name this machine: --machine one of {', '.join(sorted(st.machines))}",
                                 param_hint="--machine")
    roles = [r.strip() for r in nodes.split(",") if r.strip()]
    where = {st.machine_of(r) for r in roles}
    if not roles or None in where or len(where) != 1:
        placed = "; ".join(f"{m}: {', '.join(sec.nodes)}" for m, sec in st.machines.items())
        raise typer.BadParameter(f"'{nodes}' is not the nodes of one machine ({placed})", param_hint="--nodes")
    machine = where.pop()
    assert machine is not None
    if set(roles) != set(st.machines[machine].nodes):
        raise typer.BadParameter(f"machine '{machine}' serves {', '.join(st.machines[machine].nodes)}: serve them "
                                 "all (the station file places them together)", param_hint="--nodes")
    return machine
