"""`rio eval STATION --policy SPEC --trials N --seed S`: a policy's success rate on a station's task (typer
front door). All the work is done by `rio.workflows.eval.run_eval`, so scripts and tests call exactly what the
command runs.

Exit status: 0 when every trial ran (whatever the success rate: it is a result, not an error); 1 when a node
failed (the policy stopped, another node died), after the trials that ran are printed; 128 + the signal's
number when a signal ended it.
"""

from __future__ import annotations

import signal
from typing import Annotated

import typer

from rio.cli.args import non_negative, output_dir
from rio.cli.deploy_cmd import (
    BlendOption,
    CrossfadeOption,
    InstructionOption,
    LowpassOption,
    OnLateOption,
    PolicyOption,
    ThresholdOption,
)
from rio.cli.run_cmd import MiddlewareOption, ProfileOption, RateOption, ReadyTimeoutOption, StationArgument

#: A node failed during the evaluation (exit status).
EXIT_NODE_FAILED = 1


def eval_(
    station: StationArgument,
    policy: PolicyOption = None,
    trials: Annotated[int, typer.Option("--trials", "-n", min=1, help="Trials to run.")] = 10,
    seed: Annotated[int | None, typer.Option(
        "--seed", min=0, help="Trial k starts from the task's draw of (seed, k), the same at every run "
                              "(default: the task's own seed).")] = None,
    hold: Annotated[float, typer.Option(
        "--hold", callback=non_negative, help="A trial succeeds once the task's success has held this long "
                                              "(task seconds).")] = 0.3,
    record: Annotated[str | None, typer.Option(
        "--record", callback=output_dir, help="Record every trial as an episode of the dataset DIR (created if "
                                              "absent), its task verdict in the episode's metadata.")] = None,
    instruction: InstructionOption = None,
    rate: RateOption = None,
    threshold: ThresholdOption = 0.5,
    blend: BlendOption = "crossfade",
    crossfade: CrossfadeOption = 0.1,
    on_late: OnLateOption = "hold",
    lowpass: LowpassOption = None,
    middleware: MiddlewareOption = None,
    ready_timeout: ReadyTimeoutOption = None,
    json_out: Annotated[bool, typer.Option("--json", help="Print the result as JSON (stdout).")] = False,
    profile: ProfileOption = None,
) -> None:
    """Evaluate a policy on a station's task: N seeded trials on one running station, each ended by success
    (held --hold s), the task's time limit or the policy; prints the success rate, the completion times and
    every trial."""
    from rio.policy.async_inference import AsyncConfig
    from rio.workflows.eval import run_eval

    config = AsyncConfig(request_threshold=threshold, blend=blend, crossfade_s=crossfade, on_late=on_late,
                         lowpass_hz=lowpass)
    result = run_eval(station, policy, trials=trials, seed=seed, hold_s=hold, record=record, instruction=instruction,
                      middleware=middleware, rate_hz=rate, config=config, profile=profile,
                      ready_timeout=ready_timeout, log=lambda m: typer.echo(m, err=True))
    if json_out:
        from rio.cli.output import print_json

        print_json(result.to_json())
    else:
        typer.echo(result.format())
    if result.signal:
        raise typer.Exit(128 + int(getattr(signal, result.signal, signal.SIGINT)))
    if result.failed:
        raise typer.Exit(EXIT_NODE_FAILED)
