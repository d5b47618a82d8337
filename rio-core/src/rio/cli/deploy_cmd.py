"""`rio deploy STATION --policy SPEC`: run a policy on a station (typer front door). All the work is
done by `rio.policy.deploy.run_deploy`, so scripts and tests call exactly what the command runs."""

from __future__ import annotations

from typing import Annotated

import typer

from .run_cmd import JsonOption, ProfileOption


def deploy(
    station: Annotated[str, typer.Argument(help="Station name (`rio stations list`) or path of a .toml file.")],
    policy: Annotated[str | None, typer.Option(
        "--policy", "-p", help="NAME[,key=value...] of a registered policy (`rio plugins list`), "
                               "module:PolicyNodeClass[,key=value...], or a .toml file with a \\[policy] table. "
                               "Default: the station's \\[components.policy].")] = None,
    instruction: Annotated[str | None, typer.Option(
        "--instruction", "-i", help="Task text given to the policy.")] = None,
    record: Annotated[str | None, typer.Option(
        "--record", help="Record the rollout as an episode of the dataset DIR.")] = None,
    duration: Annotated[float | None, typer.Option(
        "--duration", "-d", min=0.1, help="Stop after this many seconds.")] = None,
    rate: Annotated[float | None, typer.Option("--rate", help="Control rate (Hz; default: the station's).")] = None,
    threshold: Annotated[float, typer.Option(
        "--threshold", min=0.0, max=1.0,
        help="Ask for the next chunk when this fraction of the current one is left (1: ask continuously).")] = 0.5,
    blend: Annotated[str, typer.Option(
        "--blend", help="Overlapping chunks: latest, crossfade or ensemble.")] = "crossfade",
    crossfade: Annotated[float, typer.Option("--crossfade", min=0.0, help="Cross-fade length (s).")] = 0.1,
    on_late: Annotated[str, typer.Option(
        "--on-late", help="Policy late: hold, or continue along the last chunk.")] = "hold",
    lowpass: Annotated[float | None, typer.Option(
        "--lowpass", min=0.1, help="Low-pass cutoff on commands (Hz).")] = None,
    middleware: Annotated[str | None, typer.Option(
        "--middleware", "-m", help="Override the station's middleware.")] = None,
    json_out: JsonOption = False,
    profile: ProfileOption = None,
) -> None:
    """Deploy a policy with asynchronous chunked inference; prints a summary when it ends."""
    from ..policy.async_inference import AsyncConfig
    from ..policy.deploy import run_deploy
    from .run_cmd import finish

    config = AsyncConfig(request_threshold=threshold, blend=blend, crossfade_s=crossfade, on_late=on_late,
                         lowpass_hz=lowpass)
    summary = run_deploy(station, policy, instruction=instruction, record=record, duration=duration,
                         middleware=middleware, rate_hz=rate, config=config, profile=profile,
                         log=lambda m: typer.echo(m, err=True))
    finish(summary, json_out)
