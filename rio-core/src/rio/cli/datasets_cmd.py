"""`rio datasets info|repair|import|formats`: inspect, repair and import native RIO datasets.

`info` verifies every episode against its recorded sizes and sha256 unless `--no-verify`, and lists
the damaged files per episode (exit 1 when any is). Damaged metadata is one line naming the file."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Annotated

import typer

from .args import existing_path, not_empty, output_dir

app = typer.Typer(help="Recorded datasets: inspect, repair after a crash, import from other formats.",
                  no_args_is_help=True)


@contextlib.contextmanager
def damaged_warnings() -> Iterator[None]:
    """Show each DamagedEpisodeWarning (an episode used with --allow-damaged) as one CLI warning line."""
    import warnings

    from ..recording import DamagedEpisodeWarning
    from .output import warn

    def show(message, category, *args, **kwargs) -> None:  # noqa: ANN001 - warnings.showwarning's signature
        if issubclass(category, DamagedEpisodeWarning):
            from rich.markup import escape

            warn(escape(str(message)))
        else:
            previous(message, category, *args, **kwargs)

    with warnings.catch_warnings():
        warnings.simplefilter("always", DamagedEpisodeWarning)
        previous = warnings.showwarning
        warnings.showwarning = show
        yield


@app.command("info")
def info(
    dataset: Annotated[str, typer.Argument(callback=not_empty, help="Native RIO dataset directory.")],
    verify: Annotated[bool, typer.Option("--verify/--no-verify",
                                         help="Check every file against its recorded size and sha256 "
                                              "(--no-verify: faster, reads only the metadata).")] = True,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """Episodes, steps, rate, cameras, size, damaged files, and anything left by a crash."""
    from ..recording import Dataset
    from .output import console, print_json, table, warn

    ds = Dataset(dataset)
    summary = ds.summary()
    damaged = ds.damaged() if verify else {}
    if verify:
        summary["damaged"] = damaged
    if as_json:
        print_json({**summary, "episode_list": ds.episodes})
        raise typer.Exit(1 if damaged else 0)
    c = console()
    c.print(f"dataset {summary['path']}: {summary['episodes']} episodes, {summary['steps']} steps, "
            f"{summary['duration_s']:.1f} s at {summary['fps']} Hz, {summary['bytes'] / 1e6:.1f} MB", markup=False)
    c.print(f"station: {summary['station']}  embodiment: {summary['embodiment']}  "
            f"streams: {', '.join(summary['streams']) or 'none'}", markup=False)
    table(None, ("episode", "steps", "seconds", "instruction", "cameras", "note"),
          [(e["index"], e.get("length"), f"{e.get('duration_s', 0):.2f}", e.get("instruction") or "",
            ", ".join(f"{k} {v.get('frames')}f@{v.get('rate')}" for k, v in e.get("cameras", {}).items()),
            _note(e, damaged)) for e in ds.episodes])
    for p in summary["partial"]:
        warn(f"{p}: an interrupted episode; run `rio datasets repair {dataset}`")
    if summary["discarded"]:
        c.print(f"{summary['discarded']} discarded episodes kept in .discarded/ (delete them to free space)",
                markup=False)
    if not verify:
        c.print("not verified (--no-verify): run without it to check every file's sha256", markup=False)
        return
    if damaged:
        from rich.markup import escape

        for name, bad in damaged.items():
            warn(escape(f"{name} is damaged: {'; '.join(bad)}"))
        warn(f"{len(damaged)} damaged episodes: export and replay refuse them (--allow-damaged to use them anyway)")
        raise typer.Exit(1)
    c.print("verified: every file matches its recorded sha256", markup=False)


def _note(entry: dict, damaged: dict[str, list[str]]) -> str:
    """The table's note for one episode: damaged and/or repaired."""
    notes = (["DAMAGED"] if entry.get("dir") in damaged else []) + (["repaired"] if entry.get("repaired") else [])
    return ", ".join(notes)


@app.command("repair")
def repair(dataset: Annotated[str, typer.Argument(callback=not_empty, help="Native RIO dataset directory.")]) -> None:
    """Finish episodes interrupted by a crash, rebuild damaged metadata and the index. Finished
    episodes' data is never modified and nothing is deleted: what cannot be used goes to .quarantine/."""
    from rich.markup import escape

    from ..recording import repair_dataset
    from .output import console, warn

    report = repair_dataset(dataset)
    c = console()
    for line in report.repaired:
        c.print(f"repaired {line}", markup=False)
    for line in report.quarantined:
        c.print(f"quarantined {line}", markup=False)
    for line in report.removed:
        c.print(f"removed {line}", markup=False)
    for line in report.index_notes:
        c.print(f"index: {line}", markup=False)
    for line in report.damaged:
        warn(escape(f"damaged (left as is): {line}"))
    if not report.changed:
        c.print("nothing to repair", markup=False)


@app.command("import")
def import_(
    src: Annotated[str, typer.Argument(callback=existing_path, help="Dataset in another format.")],
    out: Annotated[str, typer.Argument(callback=output_dir, help="Native RIO dataset directory to write.")],
    fmt: Annotated[str, typer.Option("--format", "-f", callback=not_empty,
                                     help="Its format (see `rio datasets formats`).")],
    option: Annotated[list[str] | None, typer.Option("--option", "-o", help="Format option key=value.")] = None,
) -> None:
    """Import a LeRobot v3 / Zarr / HDF5 dataset as a native RIO dataset."""
    from pathlib import Path

    from ..recording.format import get_format
    from .export_cmd import parse_options, run_with_progress
    from .output import console

    f = get_format(fmt, parse_options(option))
    if not f.can_import:
        raise typer.BadParameter(f"format '{fmt}' cannot import")
    from ..errors import ConfigError, RioError

    try:
        result = run_with_progress(f"import {fmt}", lambda p: f.import_(Path(src), Path(out), progress=p))
    except RioError:
        raise
    except Exception as e:  # the format's reader on something that is not such a dataset: one line
        raise ConfigError(f"{src}: cannot be read as a '{fmt}' dataset ({type(e).__name__}: {e})") from None
    console().print(f"imported {result.get('episodes')} episodes into {out}", markup=False)


@app.command("formats")
def formats() -> None:
    """Dataset formats provided by installed plugins."""
    from ..plugins import get_registry
    from .output import table, warn_problems

    reg = get_registry()
    table("dataset formats", ("name", "plugin", "description"),
          [(s.name, s.plugin, s.description) for s in reg.specs("rio_dataset_formats")])
    warn_problems(reg)
