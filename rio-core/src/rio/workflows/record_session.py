"""`record_session`: record N episodes in one station session (`rio teleop --record DIR --episodes N`).

The station starts once and its nodes keep running (and keep their process ids) from the first episode to the
last; restarting every node between episodes cost 7 s to tens of seconds each. Each episode is one run of the
control loop with the same controller (`reset()` starts it afresh: a scripted device restarts its script).
Between two episodes, during a reset period shown as a countdown:

- with `home_speed`, every joint device goes to its home pose at that speed (`rio.workflows.home`: what a real
  robot needs before the next demonstration);
- otherwise, on a stand-in station (sim, fake, emulator), the robot goes back to where the session started it,
  as `rio eval` does between trials (`return_home`); on real hardware without `home_speed` nothing moves;
- the next episode's scene is reset by `Env.reset(seed, episode)` when its loop starts (a sim task puts its
  objects at that episode's seeded start), with `episode` the index the recorder gives the next episode.

After each run `decide(summary, recorder)` (the command line: the device's button, a key, or `--on-end`) says
keep, discard or re-record the episode and whether the session goes on. A run ended by a stop signal is decided
like any other (the command line asks when interactive and keeps when headless) and then ends the session.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from typing import Any

import numpy as np

from rio import clock
from rio.loop.control_loop import ControlLoop, Tick
from rio.loop.summary import RunSummary

#: Seconds between two episodes (the reset period, shown as a countdown), unless the session says otherwise.
RESET_S = 3.0


def pause_devices(clients: dict[str, Any]) -> None:
    """Tell the teleop devices that have a `pause()` API (the keyboard) to stop reading input until their next
    `reset()`: between episodes the terminal is the prompt's."""
    for role, c in clients.items():
        if role.startswith("teleop") and "pause" in dir(c):
            with contextlib.suppress(Exception):  # a device that cannot pause must not end the session
                c.pause()


def countdown(seconds: float, stop: Any, say: Callable[[str], None], label: str,
              busy: Callable[[], None] | None = None) -> None:
    """Run `busy()` (the reset: homing, going back), then wait out the rest of `seconds`, saying how long is left
    once a second; a stop signal ends the wait at once."""
    t_end = clock.now() + seconds
    say(f"{label} in {seconds:.0f} s (resetting)")
    if busy is not None:
        busy()
    left = int(np.ceil(t_end - clock.now()))
    while left > 0 and not (stop is not None and stop.received):
        say(f"  {left} ...")
        clock.precise_wait(min(t_end, clock.now() + 1.0))
        left = int(np.ceil(t_end - clock.now() - 1e-3))


def record_session(station: Any, make_controller: Callable[[Any], Any], recorder: Any,
                   decide: Callable[[RunSummary, Any, Any], tuple[str, bool]], *, middleware: str | None = None,
                   rate_hz: float | None = None, duration: float | None = None, instruction: str | None = None,
                   profile: str | None = None, log: Callable[[str], None] | None = print, seed: int | None = None,
                   ready_timeout: float | None = None, status: bool = False, home_speed: float | None = None,
                   reset_s: float = RESET_S, on_tick: Callable[[Tick], None] | None = None,
                   on_start: Callable[[Any], None] | None = None) -> RunSummary:
    """Record episodes into the open `recorder` until it has its count (`recorder.done`), `decide` ends the
    session, or a stop signal does; one station session throughout (see the module docstring).
    `decide(summary, recorder, stop)` (`stop`: the session's stop signals) returns (what to do with the episode:
    "keep", "discard" or "rerecord"; whether to go on). `on_start(session)` runs once the station is up (tests
    read its node pids there). Returns the last run's summary."""
    from rio.workflows.eval import return_home
    from rio.workflows.home import home_devices, is_stand_in
    from rio.workflows.run import _with_status_line, finish_session, open_session

    say = log or (lambda _m: None)
    summary: RunSummary | None = None
    with open_session(station, middleware=middleware, rate_hz=rate_hz, instruction=instruction, profile=profile,
                      log=log, seed=seed, ready_timeout=ready_timeout) as session:
        env, stop, prof = session.env, session.stop, session.profile
        if on_start is not None:
            on_start(session)
        controller = make_controller(session)
        if "embodiment" not in recorder.info:
            recorder.describe_env(env)
        start = np.asarray(env.get_state().observation.proprio, dtype=np.float64)  # where the station starts it
        stand_in = is_stand_in(session.station)

        def reset() -> None:
            if home_speed is not None:
                for line in home_devices(env.robot.clients, speed=home_speed, log=say).lines():
                    say(line)
            elif stand_in:
                return_home(env, start, session.rate_hz)

        if home_speed is not None:
            reset()
        first = True
        while not recorder.done and not stop.received:
            if not first:
                countdown(reset_s, stop, say, f"episode {len(recorder.kept) + 1}"
                          + (f"/{recorder.target}" if recorder.target else ""), reset)
                if stop.received:
                    break
            first = False
            env.seed, env.episode = seed, recorder.next_index()
            with contextlib.ExitStack() as per_episode:
                tick = _with_status_line(per_episode, on_tick, recorder.root, env) if status else on_tick
                loop = ControlLoop(env, controller, rate_hz=session.rate_hz, duration=duration, recorder=recorder,
                                   on_tick=tick, stop=stop, trace=prof.trace if prof is not None else None, log=say)
                summary = loop.run()
            pause_devices(getattr(controller, "devices", None) or {})
            choice, go_on = decide(summary, recorder, stop)
            if choice == "keep":
                meta = recorder.keep()
                say(f"kept episode {meta['index'] if meta else '(empty, dropped)'} in {recorder.root}")
            else:
                recorder.discard()
                say("discarded" if choice == "discard" else "discarded; recording it again")
            if summary.signal or not go_on:
                break
    assert summary is not None or stop.received  # a signal during start-up ends before any episode
    if summary is None:
        summary = RunSummary("teleop", getattr(session.station, "name", str(station)))
        summary.reason, summary.signal = f"stopped by {stop.received}", stop.received
    return finish_session(summary, session, str(recorder.root))
