"""`rio export DATASET --format lerobot|zarr|hdf5 OUT`: a native dataset to another format, with a
progress bar. Formats come from plugins (`rio_dataset_formats` hook; rio-datasets ships these).

The episodes are verified first: a damaged one (a file differing from its recorded sha256) is refused
in one line naming it, unless `--allow-damaged` (then a warning per damaged episode). `--episodes` is
checked against the dataset's episodes before anything is read (a range is never expanded past them).
A failed export leaves no partial output behind and ends in one line, and an output inside the dataset is
refused, and so is one that exists and is not empty unless `--overwrite` (the old output is kept until the
new one has finished: `rio.recording.format.export_dataset`)."""

from __future__ import annotations

import bisect
import re
from typing import Annotated

import typer

from rio.cli.args import not_empty, writable_problem
from rio.errors import ConfigError

#: An episode index or a range of them; 18 digits at most (an int64, and no 10^5-digit number to parse).
_EPISODE_PART = re.compile(r"^\s*(\d{1,18})\s*(?:-\s*(\d{1,18})\s*)?$")


def parse_options(items: list[str] | None) -> dict[str, str]:
    out = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"--option '{item}' is not key=value")
        out[key.strip()] = value.strip()
    return out


def parse_episodes(text: str | None) -> list[tuple[int, int]] | None:
    """'0,2,5-7' -> [(0, 0), (2, 2), (5, 7)] (inclusive ranges, never expanded here: '0-99999999999' is two
    numbers, not 10^11 of them); anything else is one ConfigError quoting the bad part."""
    if text is None:
        return None
    out: list[tuple[int, int]] = []
    for part in text.split(","):
        m = _EPISODE_PART.match(part)
        if m is None:
            raise ConfigError(f"--episodes '{text}': '{part}' is not an episode index or a range like 5-7")
        a, b = int(m.group(1)), int(m.group(2) if m.group(2) is not None else m.group(1))
        if b < a:
            raise ConfigError(f"--episodes '{text}': the range '{part.strip()}' ends before it starts")
        out.append((a, b))
    return out


def choose_episodes(text: str, ranges: list[tuple[int, int]], have: list[int]) -> list[int]:
    """The episodes `ranges` name, in the order given (each once), every one of them checked against the
    dataset's episode indices `have` first: one missing is one ConfigError naming it and what there is.
    Costs the size of the dataset, not of the ranges."""
    known = sorted(set(have))
    out: list[int] = []
    seen: set[int] = set()
    for a, b in ranges:
        lo, hi = bisect.bisect_left(known, a), bisect.bisect_right(known, b)
        if hi - lo != b - a + 1:  # some index of a..b is not an episode: the first one missing
            missing = next((k for i, k in enumerate(range(a, b + 1)) if lo + i >= hi or known[lo + i] != k))
            raise ConfigError(f"--episodes '{text}': the dataset has no episode {missing} "
                              f"(its episodes: {_ranges_text(known)})")
        for k in known[lo:hi]:
            if k not in seen:
                seen.add(k)
                out.append(k)
    return out


def _ranges_text(indices: list[int]) -> str:
    """[0, 1, 2, 5] -> '0-2, 5' (sorted input); 'none' for no episode."""
    runs: list[list[int]] = []
    for k in indices:
        if runs and k == runs[-1][1] + 1:
            runs[-1][1] = k
        else:
            runs.append([k, k])
    return ", ".join(f"{a}-{b}" if b > a else f"{a}" for a, b in runs) or "none"


def output_path(value: str) -> str:
    """An export's output: a directory, or the one file some formats write (robomimic HDF5); one that
    exists and is not empty is refused later, naming --overwrite (`export_dataset`). It must be somewhere
    this user can create things (`writable_problem`), checked before any episode is read."""
    from pathlib import Path

    not_empty(value)
    if (why := writable_problem(Path(value).parent if Path(value).is_file() else Path(value))):
        raise typer.BadParameter(f"'{value}' cannot be written: {why}")
    return value


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
    out: Annotated[str, typer.Argument(callback=output_path, help="Where to write the exported dataset.")],
    fmt: Annotated[str, typer.Option("--format", "-f", callback=not_empty,
                                     help="Dataset format (see `rio datasets formats`).")],
    episodes: Annotated[str | None, typer.Option("--episodes", "-e", help="Only these episodes: 0,2,5-7.")] = None,
    option: Annotated[list[str] | None,
                      typer.Option("--option", "-o", help="Format option key=value (repeat).")] = None,
    allow_damaged: Annotated[bool, typer.Option("--allow-damaged",
                                                help="Export episodes whose files fail their sha256.")] = False,
    overwrite: Annotated[bool, typer.Option("--overwrite",
                                            help="Replace an existing output (kept until the new export has "
                                                 "finished).")] = False,
) -> None:
    """Export a recorded dataset (e.g. `rio export data/pick --format lerobot out/pick_lerobot`)."""
    from pathlib import Path

    from rio.cli.datasets_cmd import damaged_warnings
    from rio.cli.output import console
    from rio.machine.confine import is_inside
    from rio.recording import Dataset
    from rio.recording.format import export_dataset, get_format

    ranges = parse_episodes(episodes)
    opts = parse_options(option)
    target = Path(out)
    occupied = target.is_file() or target.is_symlink() or (target.is_dir() and any(target.iterdir()))
    if occupied and not overwrite and not is_inside(target, Path(dataset)):  # inside: export_dataset says so
        raise ConfigError(f"{out} exists and is not empty; --overwrite replaces it")  # before any episode is read
    ds = Dataset(dataset, allow_damaged=allow_damaged)
    chosen = None if ranges is None else choose_episodes(str(episodes), ranges, [e["index"] for e in ds.episodes])
    f = get_format(fmt, opts)
    if not f.can_export:
        raise ConfigError(f"format '{fmt}' cannot export")
    with damaged_warnings():
        result = run_with_progress(f"export {fmt}", lambda p: export_dataset(f, ds, Path(out), episodes=chosen,
                                                                             progress=p, overwrite=overwrite))
    console().print(f"exported {result.get('episodes')} episodes to {out} ({fmt})", markup=False)
    for key, value in result.items():
        if key not in ("episodes", "path", "warnings"):
            console().print(f"  {key}: {value}", markup=False)
    from rich.markup import escape

    from rio.cli.output import warn

    for line in result.get("warnings") or []:
        warn(escape(str(line)))
