"""`rio deploy STATION --policy SPEC`: run a policy on a station (typer front door). All the work is
done by `rio.workflows.deploy.run_deploy`, so scripts and tests call exactly what the command runs."""

from __future__ import annotations

from typing import Annotated

import typer

from rio.cli.args import fraction, key_values, non_negative, not_empty, one_of, positive
from rio.cli.run_cmd import (
    DurationOption,
    JsonOption,
    MiddlewareOption,
    ProfileOption,
    QuietOption,
    RateOption,
    ReadyTimeoutOption,
    RecordOption,
    SeedOption,
    StationArgument,
    TeleopOption,
    TeleopSetOption,
)

PolicyOption = Annotated[str | None, typer.Option(
    "--policy", "-p", callback=not_empty, help="NAME[,key=value...] of a registered policy (`rio plugins list`), "
                           "module:PolicyNodeClass[,key=value...], or a .toml file with a \\[policy] table. "
                           "Default: the station's \\[components.policy].")]
InstructionOption = Annotated[str | None, typer.Option("--instruction", "-i", help="Task text given to the policy.")]
ThresholdOption = Annotated[float, typer.Option(
    "--threshold", callback=fraction,
    help="Ask for the next chunk when this fraction of the current one is left (1: ask continuously).")]
BlendOption = Annotated[str, typer.Option(
    "--blend", callback=one_of("latest", "crossfade", "ensemble"), help="Overlapping chunks: latest, crossfade or "
                                                                        "ensemble.")]
CrossfadeOption = Annotated[float, typer.Option("--crossfade", callback=non_negative, help="Cross-fade length (s).")]
OnLateOption = Annotated[str, typer.Option(
    "--on-late", callback=one_of("hold", "continue"), help="Policy late: hold, or continue along the last chunk.")]
LowpassOption = Annotated[float | None, typer.Option(
    "--lowpass", callback=positive, help="Low-pass cutoff on commands (Hz).")]


def deploy(
    station: StationArgument,
    policy: PolicyOption = None,
    instruction: InstructionOption = None,
    record: RecordOption = None,
    seed: SeedOption = None,
    duration: DurationOption = None,
    rate: RateOption = None,
    threshold: ThresholdOption = 0.5,
    blend: BlendOption = "crossfade",
    crossfade: CrossfadeOption = 0.1,
    on_late: OnLateOption = "hold",
    lowpass: LowpassOption = None,
    middleware: MiddlewareOption = None,
    ready_timeout: ReadyTimeoutOption = None,
    quiet: QuietOption = False,
    device: TeleopOption = None,
    teleop_set: TeleopSetOption = None,
    json_out: JsonOption = False,
    profile: ProfileOption = None,
) -> None:
    """Deploy a policy with asynchronous chunked inference; prints a summary when it ends. A teleop device
    (--teleop) runs beside it for a policy that reads one (a locomotion policy's velocity command)."""
    from rio.cli.run_cmd import finish, shows_status
    from rio.policy.async_inference import AsyncConfig
    from rio.workflows.deploy import run_deploy

    config = AsyncConfig(request_threshold=threshold, blend=blend, crossfade_s=crossfade, on_late=on_late,
                         lowpass_hz=lowpass)
    summary = run_deploy(station, policy, instruction=instruction, record=record, duration=duration,
                         middleware=middleware, rate_hz=rate, config=config, profile=profile,
                         device=device, device_config=key_values(teleop_set, "--teleop-set"),
                         log=lambda m: typer.echo(m, err=True), seed=seed, ready_timeout=ready_timeout,
                         status=shows_status(quiet, json_out))
    finish(summary, json_out)
