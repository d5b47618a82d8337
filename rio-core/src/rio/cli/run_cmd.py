"""`rio run STATION --controller module:Class`: a user's own controller on the one control loop, plus
what every workflow command shares: `--json`, `--profile`, and how a run ends the process.

Exit status of every workflow command (teleop, deploy, replay, run, serve): `rio.cli.exit_status`, one
table (0 only when the run ended as asked with no node error, fault or safety stop and every arm followed),
after the summary was printed.
"""

from __future__ import annotations

from typing import Annotated, Any

import typer

from rio.cli.args import complete_station, key_values, known_station, not_empty, output_dir, positive, rate_hz
from rio.cli.exit_status import EXIT_NOT_FOLLOWED, exit_code

__all__ = ["EXIT_NOT_FOLLOWED", "exit_code", "finish", "load_controller", "run", "shows_status"]

JsonOption = Annotated[bool, typer.Option("--json", help="Print the summary as JSON (stdout).")]
ProfileOption = Annotated[str | None, typer.Option(
    "--profile", callback=output_dir, metavar="DIR",
    help="Write a trace (Perfetto / chrome://tracing), a timeline PNG and a CPU/RAM/GPU table to this directory.")]
StationArgument = Annotated[str, typer.Argument(
    callback=known_station, autocompletion=complete_station,
    help="Station name (`rio stations list`) or path of a .toml file.")]
DurationOption = Annotated[float | None, typer.Option(
    "--duration", "-d", callback=positive, metavar="SECONDS", help="Stop after this many seconds.")]
RateOption = Annotated[float | None, typer.Option(
    "--rate", callback=rate_hz, metavar="HZ", help="Control rate (Hz, 1 to 10000; default: the station's).")]
RecordOption = Annotated[str | None, typer.Option(
    "--record", callback=output_dir, metavar="DIR",
    help="Record the run as an episode of the dataset DIR (created if absent).")]
MiddlewareOption = Annotated[str | None, typer.Option(
    "--middleware", "-m", callback=not_empty, metavar="NAME", help="Override the station's middleware.")]
ReadyTimeoutOption = Annotated[float | None, typer.Option(
    "--ready-timeout", callback=positive, metavar="SECONDS",
    help="Seconds the station's nodes may take to start (default: the station's ready_timeout_s, 60 s).")]
QuietOption = Annotated[bool, typer.Option(
    "--quiet", "-q", help="No live status line (shown only when the output is a terminal, and never with --json).")]
SeedOption = Annotated[int | None, typer.Option(
    "--seed", min=0, metavar="SEED",
    help="On a station with a task (a sim world's \\[task]): the run's seed; episode k starts from the draw of "
         "(seed, k), k the recorded episode's index (default: the task's own seed).")]
TeleopOption = Annotated[str | None, typer.Option(
    "--teleop", "-t", callback=not_empty, metavar="DEVICE",
    help="Teleop device: keyboard, scripted, or any registered teleop driver (default: the station's own).")]
TeleopSetOption = Annotated[list[str] | None, typer.Option(
    "--teleop-set", metavar="KEY=VALUE",
    help="KEY=VALUE for the teleop device's config, over the station's (JSON values; repeatable), e.g. "
         "--teleop-set speed=0.05 --teleop-set hand=left")]


def shows_status(quiet: bool, json_out: bool) -> bool:
    """Whether a workflow shows its live status line: only to a person at a terminal."""
    import sys

    return not quiet and not json_out and sys.stdout.isatty() and sys.stderr.isatty()


def finish(summary: Any, json_out: bool, printed: bool = False) -> None:
    """Print the run's summary (text or JSON; `printed`: the text is out already) and end the command
    with the documented status."""
    if json_out:
        from rio.cli.output import print_json

        print_json(summary.to_json())
    elif not printed:
        typer.echo(summary.format())
    code = exit_code(summary)
    if code:
        raise typer.Exit(code)


def load_controller(spec: str) -> type:
    """'package.module:Class' -> the class (a clear error naming what is missing)."""
    import importlib

    hint = "'--controller'"
    module, sep, attr = spec.partition(":")
    if not sep or not module or not attr:
        raise typer.BadParameter(f"'{spec}': write module:Class (e.g. my_lab.controllers:Wave)",
                                 param_hint=hint)
    try:
        mod = importlib.import_module(module)
    except ImportError as e:
        raise typer.BadParameter(f"cannot import '{module}': {e}", param_hint=hint) from e
    cls = getattr(mod, attr, None)
    if cls is None:
        raise typer.BadParameter(f"module '{module}' has no '{attr}'", param_hint=hint)
    missing = [m for m in ("reset", "step", "done") if not callable(getattr(cls, m, None))]
    if missing:
        raise typer.BadParameter(f"{spec} is not a controller: it lacks {missing} (docs/controllers.md)",
                                 param_hint=hint)
    return cls


def run(
    station: StationArgument,
    controller: Annotated[str, typer.Option("--controller", "-c", callback=not_empty,
                                            help="module:Class of your controller (docs/controllers.md).")],
    option: Annotated[list[str] | None, typer.Option("--set", help="key=value given to the controller's "
                                                                   "constructor (JSON values; repeatable).")] = None,
    duration: DurationOption = None,
    rate: RateOption = None,
    instruction: Annotated[str | None, typer.Option("--instruction", "-i", help="Task text stored with every "
                                                                               "step.")] = None,
    record: RecordOption = None,
    middleware: MiddlewareOption = None,
    ready_timeout: ReadyTimeoutOption = None,
    quiet: QuietOption = False,
    json_out: JsonOption = False,
    profile: ProfileOption = None,
) -> None:
    """Run your own controller on a station, with the loop, recording, signals and summary of every
    other workflow."""
    from rio.workflows.run import run_workflow

    cls = load_controller(controller)
    kwargs = key_values(option, "--set")
    from_session = getattr(cls, "from_session", None)  # a controller that connects nodes of its own

    def make(session: Any) -> Any:
        return from_session(session, **kwargs) if from_session is not None else cls(**kwargs)

    summary = run_workflow(station, make, middleware=middleware, rate_hz=rate,
                           duration=duration, instruction=instruction, record=record, profile=profile,
                           log=lambda m: typer.echo(m, err=True), ready_timeout=ready_timeout,
                           status=shows_status(quiet, json_out))
    finish(summary, json_out)
