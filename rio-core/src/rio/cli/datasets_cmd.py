"""`rio datasets info|repair|import|merge|view|formats`: inspect, repair, import, merge and view native RIO
datasets.

`info` verifies every episode against its recorded sizes and sha256 unless `--no-verify`, and lists
the damaged files per episode (exit 1 when any is). Damaged metadata is one line naming the file."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Annotated

import typer

from rio.cli.args import existing_path, not_empty, output_dir

app = typer.Typer(help="Recorded datasets: inspect, repair after a crash, import from other formats, merge "
                       "embodiments, view an episode.",
                  no_args_is_help=True)


@contextlib.contextmanager
def damaged_warnings() -> Iterator[None]:
    """Show each DamagedEpisodeWarning (an episode used with --allow-damaged) as one CLI warning line."""
    import warnings

    from rio.cli.output import warn
    from rio.recording import DamagedEpisodeWarning

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
    from rio.cli.output import console, print_json, table, warn
    from rio.recording import Dataset

    ds = Dataset(dataset)
    summary = ds.summary()
    damaged = ds.damaged() if verify else {}
    if verify:
        summary["damaged"] = damaged
    from rio.recording.merge import embodiment_mix

    summary["embodiments"] = mix = embodiment_mix(ds)  # {tag: episodes}: a merged dataset holds several
    if as_json:
        print_json({**summary, "episode_list": ds.episodes})
        raise typer.Exit(1 if damaged else 0)
    c = console()
    c.print(f"dataset {summary['path']}: {summary['episodes']} episodes, {summary['steps']} steps, "
            f"{summary['duration_s']:.1f} s at {summary['fps']} Hz, {summary['bytes'] / 1e6:.1f} MB", markup=False)
    c.print(f"station: {summary['station']}  embodiment: {summary['embodiment']}  "
            f"streams: {', '.join(summary['streams']) or 'none'}", markup=False)
    if len(mix) > 1:
        c.print("embodiments: " + ", ".join(f"{tag} ({n} episode{'s' if n != 1 else ''})" for tag, n in mix.items()),
                markup=False, soft_wrap=True)
    table(None, ("episode", "steps", "seconds", "instruction", "cameras", "note"),
          [(e["index"], e.get("length"), f"{e.get('duration_s', 0):.2f}", e.get("instruction") or "",
            ", ".join(_camera_text(k, v) for k, v in e.get("cameras", {}).items()),
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


def _camera_text(key: str, stream: dict) -> str:
    """'front.rgb 90f@30 (measured 29.7)': frames, the configured rate the video is encoded at, and the
    rate the frames really came at, when recorded (an episode recorded before it was kept has none)."""
    text = f"{key} {stream.get('frames')}f@{stream.get('rate')}"
    measured = stream.get("measured_rate")
    return text + (f" (measured {measured:g})" if isinstance(measured, (int, float)) else "")


def _note(entry: dict, damaged: dict[str, list[str]]) -> str:
    """The table's note for one episode: damaged and/or repaired."""
    notes = (["DAMAGED"] if entry.get("dir") in damaged else []) + (["repaired"] if entry.get("repaired") else [])
    return ", ".join(notes)


@app.command("repair")
def repair(dataset: Annotated[str, typer.Argument(callback=not_empty, help="Native RIO dataset directory.")]) -> None:
    """Finish episodes interrupted by a crash, rebuild damaged metadata and the index. Finished
    episodes' data is never modified and nothing is deleted: what cannot be used goes to .quarantine/."""
    from rich.markup import escape

    from rio.cli.output import console, warn
    from rio.recording import repair_dataset

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

    from rio.cli.export_cmd import parse_options, run_with_progress
    from rio.cli.output import console
    from rio.recording.format import get_format

    f = get_format(fmt, parse_options(option))
    if not f.can_import:
        raise typer.BadParameter(f"format '{fmt}' cannot import")
    from rio.errors import ConfigError, RioError

    try:
        result = run_with_progress(f"import {fmt}", lambda p: f.import_(Path(src), Path(out), progress=p))
    except RioError:
        raise
    except Exception as e:  # the format's reader on something that is not such a dataset: one line
        raise ConfigError(f"{src}: cannot be read as a '{fmt}' dataset ({type(e).__name__}: {e})") from None
    console().print(f"imported {result.get('episodes')} episodes into {out}", markup=False)


def _existing_dirs(values: list[str] | None) -> list[str] | None:
    """Each input of `merge` names an existing directory (that it is a dataset is checked when opened)."""
    from pathlib import Path

    for v in values or []:
        not_empty(v)
        if not Path(v).is_dir():
            raise typer.BadParameter(f"'{v}' is not a directory" if Path(v).exists() else f"'{v}' does not exist")
    return values


@app.command("merge")
def merge(
    dataset: Annotated[list[str], typer.Argument(callback=_existing_dirs, show_default=False,
                                                 help="Native RIO datasets to merge (two or more).")],
    out: Annotated[str, typer.Argument(callback=output_dir, help="New native dataset to write (absent or empty).")],
) -> None:
    """Merge datasets of different morphologies into one: fields padded to the largest size, per-episode
    masks and embodiment tags, the union of cameras (docs/datasets.md). Inputs are only read."""
    from rio.cli.output import console
    from rio.recording.merge import merge_datasets

    err = console(stderr=True)
    result = merge_datasets(dataset, out, progress=lambda line: err.print(line, markup=False, soft_wrap=True))
    c = console()
    c.print(f"merged {len(result['sources'])} datasets into {out}: {result['episodes']} episodes, "
            f"{result['steps']} steps at {result['fps']:g} Hz", markup=False, soft_wrap=True)
    c.print("embodiments: " + ", ".join(f"{t} ({n})" for t, n in result["embodiments"].items()), markup=False,
            soft_wrap=True)
    for name, f in result["fields"].items():
        if len({tuple(s) for s in f["sources"].values()}) > 1 or len(f["sources"]) < len(result["sources"]):
            c.print(f"  padded {name} to {tuple(f['shape'])}", markup=False, soft_wrap=True)
    c.print(f"  cameras: {', '.join(result['streams']) or 'none'} (an episode lacking one has no frames for it)",
            markup=False, soft_wrap=True)


@app.command("formats")
def formats(as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False) -> None:
    """Dataset formats provided by installed plugins."""
    from rio.cli.output import print_json, table, warn_problems
    from rio.plugins import get_registry

    reg = get_registry()
    if as_json:
        print_json([{"name": s.name, "plugin": s.plugin, "target": s.target, "description": s.description}
                    for s in reg.specs("rio_dataset_formats")])
        return
    table("dataset formats", ("name", "plugin", "description"),
          [(s.name, s.plugin, s.description) for s in reg.specs("rio_dataset_formats")])
    warn_problems(reg)


@app.command("view")
def view(
    dataset: Annotated[str, typer.Argument(callback=not_empty, help="Native RIO dataset directory.")],
    episode: Annotated[int | None, typer.Option("--episode", "-e", min=0,
                                                help="Episode index (default: the first).")] = None,
    save: Annotated[str | None, typer.Option("--save", callback=not_empty,
                                             help="Write a rerun .rrd file instead of opening the viewer "
                                                  "(without a display it is always written).")] = None,
    allow_damaged: Annotated[bool, typer.Option("--allow-damaged",
                                                help="View an episode whose files fail their sha256.")] = False,
) -> None:
    """An episode in rerun's viewer: cameras, state and action per joint, gripper, end-effector path."""
    from rich.markup import escape

    from rio.cli.export_cmd import run_with_progress
    from rio.cli.output import console, warn
    from rio.recording import Dataset
    from rio.recording.view import view_episode

    ds = Dataset(dataset, allow_damaged=allow_damaged)
    with damaged_warnings():
        result = run_with_progress("view", lambda p: view_episode(
            ds, episode, save=save, progress=p, warn=lambda m: warn(escape(m))))
    what = f"episode {result['episode']} of {dataset} ({result['steps']} steps)"
    if result["where"] == "viewer":
        console().print(f"{what} sent to rerun's viewer", markup=False)
    else:
        why = "no display: " if result["headless"] else ""
        console().print(f"{why}{what} saved to {result['where']} (open it with `rerun {result['where']}`)",
                        markup=False, soft_wrap=True)
