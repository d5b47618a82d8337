"""`rio export DATASET --format lerobot|zarr|hdf5 OUT`: a native dataset to another format, with a
progress bar. Formats come from plugins (`rio_dataset_formats` hook; rio-datasets ships these).

The episodes are verified first: a damaged one (a file differing from its recorded sha256) is refused
in one line naming it, unless `--allow-damaged` (then a warning per damaged episode). A failed export
leaves no partial output behind (`rio.recording.format.export_dataset`)."""

from __future__ import annotations

import re
from typing import Annotated

import typer

from rio.cli.args import not_empty, output_dir
from rio.errors import ConfigError

_EPISODE_PART = re.compile(r"^\s*(\d+)\s*(?:-\s*(\d+)\s*)?$")


def parse_options(items: list[str] | None) -> dict[str, str]:
    out = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"--option '{item}' is not key=value")
        out[key.strip()] = value.strip()
    return out


def parse_episodes(text: str | None) -> list[int] | None:
    """'0,2,5-7' -> [0, 2, 5, 6, 7]; anything else is one ConfigError quoting the bad part."""
    if text is None:
        return None
    out: list[int] = []
    for part in text.split(","):
        m = _EPISODE_PART.match(part)
        if m is None:
            raise ConfigError(f"--episodes '{text}': '{part}' is not an episode index or a range like 5-7")
        a, b = int(m.group(1)), int(m.group(2) if m.group(2) is not None else m.group(1))
        if b < a:
            raise ConfigError(f"--episodes '{text}': the range '{part.strip()}' ends before it starts")
        out.extend(k for k in range(a, b + 1) if k not in out)
    return out


def run_with_progress(label: str, fn):
    """Call fn(progress) under a rich progress bar; returns fn's result."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from rio.cli.output import console

    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=console(stderr=True), transient=False) as bar:
        task = bar.add_task(label, total=None)

        def progress(done: int, total: int, what: str) -> None:
            bar.update(task, completed=done, total=total, description=f"{label}: {what}")

        try:
            return fn(progress)
        except BaseException:
            bar.live.transient = True  # a failure ends in its one error line, not under a half-drawn bar
            raise


def export(
    dataset: Annotated[str, typer.Argument(callback=not_empty, help="Native RIO dataset directory.")],
    out: Annotated[str, typer.Argument(callback=output_dir, help="Where to write the exported dataset.")],
    fmt: Annotated[str, typer.Option("--format", "-f", callback=not_empty,
                                     help="Dataset format (see `rio datasets formats`).")],
    episodes: Annotated[str | None, typer.Option("--episodes", "-e", help="Only these episodes: 0,2,5-7.")] = None,
    option: Annotated[list[str] | None,
                      typer.Option("--option", "-o", help="Format option key=value (repeat).")] = None,
    allow_damaged: Annotated[bool, typer.Option("--allow-damaged",
                                                help="Export episodes whose files fail their sha256.")] = False,
) -> None:
    """Export a recorded dataset (e.g. `rio export data/pick --format lerobot out/pick_lerobot`)."""
    from pathlib import Path

    from rio.cli.datasets_cmd import damaged_warnings
    from rio.cli.output import console
    from rio.recording import Dataset
    from rio.recording.format import export_dataset, get_format

    chosen = parse_episodes(episodes)
    opts = parse_options(option)
    ds = Dataset(dataset, allow_damaged=allow_damaged)
    f = get_format(fmt, opts)
    if not f.can_export:
        raise ConfigError(f"format '{fmt}' cannot export")
    with damaged_warnings():
        result = run_with_progress(f"export {fmt}", lambda p: export_dataset(f, ds, Path(out), episodes=chosen,
                                                                             progress=p))
    console().print(f"exported {result.get('episodes')} episodes to {out} ({fmt})", markup=False)
    for key, value in result.items():
        if key not in ("episodes", "path"):
            console().print(f"  {key}: {value}", markup=False)
