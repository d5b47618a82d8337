"""`run_workflow`: start a station, build a controller on it, run the one `ControlLoop`, stop it all.

Every workflow (teleop, leader-follower, deploy, replay, eval, `rio run --controller`) starts the same
way and must end the same way whatever happens — a signal, a controller error, a node dying — so the
order is written here once (`open_session`): stop signals are caught from the first moment (a SIGTERM
during start-up still ends through the normal path), the profile wraps the nodes so their processes
inherit it, the recorder closes before the station stops. `run_workflow` runs one loop in a session;
`rio.workflows.eval` runs one per trial in the same session.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from rio.errors import RioError
from rio.loop.control_loop import ControlLoop, Tick
from rio.loop.signals import StopSignals
from rio.loop.summary import RunSummary


@dataclass
class Session:
    """What a controller factory gets: the connected env, the station's client factories (to connect
    teleop devices and other nodes), an exit stack for what it opens, the station and its middleware."""

    env: Any
    clients: dict[str, Any]
    stack: contextlib.ExitStack
    station: Any
    log: Callable[[str], None]
    profile: Any = None
    #: the stop signals caught for the whole session (a loop run in it ends on them)
    stop: Any = None
    #: the control rate the session's loops run at (Hz)
    rate_hz: float = 0.0

    def started(self, manager: Any) -> None:
        """Tell the run about nodes a controller started itself (`ServerManager`): with `--profile`, their
        processes get a row in the stats table."""
        if self.profile is not None:
            self.profile.watch_nodes(manager.pids())

    @property
    def middleware(self) -> Any:
        return next(iter(self.clients.values())).mw


@contextlib.contextmanager
def open_session(station: Any, *, middleware: str | None = None, rate_hz: float | None = None,
                 instruction: str | None = None, profile: str | None = None, registry: Any = None,
                 log: Callable[[str], None] | None = print, seed: int | None = None,
                 episode: int | None = None, ready_timeout: float | None = None) -> Iterator[Session]:
    """Start `station` (name, .toml path or `Station`) with its env connected, and stop it all on exit,
    whatever happens. The env starts episode `episode` of a run seeded `seed` at its next `reset()` on a
    station whose sensor runs a task (None: the task's own seed; episode 0). With `profile` (a directory)
    the session is profiled; its summary lines are in `session.profile` after the exit. `ready_timeout`:
    seconds the station's nodes may take to start (default: the station's `ready_timeout_s`)."""
    from rio.runtime.manager import ServerManager
    from rio.station.build import make_station
    from rio.station.load import load_station

    say = log or (lambda _m: None)
    with StopSignals() as stop, contextlib.ExitStack() as outer:
        st = load_station(station, registry=registry)
        prof = None
        if profile:
            from rio.profiling import Profile

            prof = outer.enter_context(Profile(profile))
        servers, clients, env = make_station(st, middleware=middleware, registry=registry)
        if env is None:
            raise RioError(f"station '{st.name}' has no arm or humanoid to drive (roles: {sorted(st.roles())})")
        remote = {m: len(sec.nodes) for m, sec in st.machines.items()}
        elsewhere = "".join(f", {n} on {m}" for m, n in remote.items())
        say(f"starting station '{st.name}' ({len(servers)} nodes here{elsewhere}, over "
            f"{next(iter(clients.values())).mw.name}) ...")
        with ServerManager(servers, station=st.name, ready_timeout=ready_timeout or st.ready_timeout_s,
                           progress=say) as manager, contextlib.ExitStack() as stack:
            session = Session(env, clients, stack, st, say, prof, stop, float(rate_hz or st.rate_hz))
            session.started(manager)
            stack.enter_context(env)
            env.instruction = instruction
            env.seed, env.episode = seed, episode or 0  # a controller may reset the env as it starts (deploy)
            yield session


def run_workflow(station: Any, make_controller: Callable[[Session], Any], *, middleware: str | None = None,
                 rate_hz: float | None = None, duration: float | None = None, instruction: str | None = None,
                 record: str | None = None, recorder: Any = None, on_tick: Callable[[Tick], None] | None = None,
                 profile: str | None = None, registry: Any = None, log: Callable[[str], None] | None = print,
                 seed: int | None = None, episode: int | None = None, ready_timeout: float | None = None,
                 status: bool = False) -> RunSummary:
    """Run the controller `make_controller(session)` builds on `station` (name, .toml path or `Station`).
    `record`: a dataset directory to record this run into as one episode; `recorder`: an open Recorder
    instead (a multi-episode session). `profile`: a directory for the trace, timeline and stats.
    A station whose sensor runs a task (a sim world's `[task]`) starts episode `episode` of a run seeded
    `seed` (`Env.reset`; None: the task's own seed); `episode` defaults to the index the recorded episode
    will get (so each episode of a dataset has its own start), else 0. `ready_timeout`: seconds the station's
    nodes may take to start (default: the station's `ready_timeout_s`). `status`: show the live status line
    (`rio.loop.status`) on the terminal while the loop runs."""
    say = log or (lambda _m: None)
    with open_session(station, middleware=middleware, rate_hz=rate_hz, instruction=instruction, profile=profile,
                      registry=registry, log=log, seed=seed, episode=episode,
                      ready_timeout=ready_timeout) as session:
        env, stack, stop = session.env, session.stack, session.stop
        controller = make_controller(session)
        if record:
            from rio.recording import Recorder

            recorder = stack.enter_context(Recorder(record, fps=session.rate_hz, env=env, instruction=instruction,
                                                    metadata={"source": f"rio {controller.name}"}))
        if episode is None and recorder is not None:
            env.episode = recorder.next_index()
        if status:
            on_tick = _with_status_line(stack, on_tick, record or getattr(recorder, "root", None), env)
        prof = session.profile
        loop = ControlLoop(env, controller, rate_hz=session.rate_hz, duration=duration, recorder=recorder,
                           on_tick=on_tick, stop=stop, trace=prof.trace if prof is not None else None, log=say)
        summary = loop.run()
    return finish_session(summary, session, record)


def finish_session(summary: RunSummary, session: Session, record: str | None = None) -> RunSummary:
    """What a summary gets once its session has stopped: where it was recorded, the profile's lines, and a
    signal that arrived while the station was stopping."""
    if record:
        summary.lines.append(f"recorded to {record}")
    if session.profile is not None:
        summary.lines += session.profile.summary_lines()
    if session.stop.received and not summary.signal:  # arrived while the station was stopping
        summary.signal = session.stop.received
    return summary


def _with_status_line(stack: contextlib.ExitStack, on_tick: Callable[[Tick], None] | None, recording: Any,
                     env: Any) -> Callable[[Tick], None]:
    """`on_tick` followed by the live status line, shown for the loop's lifetime."""
    from rich.console import Console

    from rio.loop.status import StatusLine

    label = f"{recording} episode {env.episode}" if recording is not None else None
    line = stack.enter_context(StatusLine(Console(stderr=True, highlight=False), recording=label))
    if on_tick is None:
        return line

    def both(tick: Tick) -> None:
        on_tick(tick)
        line(tick)

    return both
