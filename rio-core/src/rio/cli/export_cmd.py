"""`rio export DATASET --format lerobot|zarr|hdf5 OUT`: a native dataset to another format, with a
progress bar. Formats come from plugins (`rio_dataset_formats` hook; rio-datasets ships these)."""

from __future__ import annotations

from typing import Annotated

import typer


def parse_options(items: list[str] | None) -> dict[str, str]:
    out = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep:
            raise typer.BadParameter(f"'{item}' is not key=value")
        out[key.strip()] = value.strip()
    return out


def parse_episodes(text: str | None) -> list[int] | None:
    """'0,2,5-7' -> [0, 2, 5, 6, 7]."""
    if not text:
        return None
    out: list[int] = []
    for part in text.split(","):
        a, sep, b = part.partition("-")
        out.extend(range(int(a), int(b) + 1) if sep else [int(a)])
    return out


def run_with_progress(label: str, fn):
    """Call fn(progress) under a rich progress bar; returns fn's result."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from .output import console

    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=console(stderr=True), transient=False) as bar:
        task = bar.add_task(label, total=None)

        def progress(done: int, total: int, what: str) -> None:
            bar.update(task, completed=done, total=total, description=f"{label}: {what}")

        return fn(progress)


def export(
    dataset: Annotated[str, typer.Argument(help="Native RIO dataset directory.")],
    out: Annotated[str, typer.Argument(help="Where to write the exported dataset.")],
    fmt: Annotated[str, typer.Option("--format", "-f", help="Dataset format (see `rio datasets formats`).")],
    episodes: Annotated[str | None, typer.Option("--episodes", "-e", help="Only these episodes: 0,2,5-7.")] = None,
    option: Annotated[list[str] | None,
                      typer.Option("--option", "-o", help="Format option key=value (repeat).")] = None,
) -> None:
    """Export a recorded dataset (e.g. `rio export data/pick --format lerobot out/pick_lerobot`)."""
    from pathlib import Path

    from ..recording import Dataset
    from ..recording.format import get_format
    from .output import console

    ds = Dataset(dataset)
    f = get_format(fmt, parse_options(option))
    result = run_with_progress(f"export {fmt}", lambda p: f.export(ds, Path(out), episodes=parse_episodes(episodes),
                                                                   progress=p))
    console().print(f"exported {result.get('episodes')} episodes to {out} ({fmt})", markup=False)
    for key, value in result.items():
        if key not in ("episodes", "path"):
            console().print(f"  {key}: {value}", markup=False)
