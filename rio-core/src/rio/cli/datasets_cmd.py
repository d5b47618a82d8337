"""`rio datasets info|repair|import|formats`: inspect, repair and import native RIO datasets."""

from __future__ import annotations

from typing import Annotated

import typer

app = typer.Typer(help="Recorded datasets: inspect, repair after a crash, import from other formats.",
                  no_args_is_help=True)


@app.command("info")
def info(
    dataset: Annotated[str, typer.Argument(help="Native RIO dataset directory.")],
    verify: Annotated[bool, typer.Option("--verify", help="Check every file against its recorded sha256.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False,
) -> None:
    """Episodes, steps, rate, cameras, size, and anything left by a crash."""
    from ..recording import Dataset
    from .output import console, print_json, table, warn

    ds = Dataset(dataset)
    summary = ds.summary()
    damaged = {}
    if verify:
        for ep in ds:
            bad = ep.verify()
            if bad:
                damaged[ep.path.name] = bad
        summary["damaged"] = damaged
    if as_json:
        print_json({**summary, "episode_list": ds.episodes})
        return
    c = console()
    c.print(f"dataset {summary['path']}: {summary['episodes']} episodes, {summary['steps']} steps, "
            f"{summary['duration_s']:.1f} s at {summary['fps']} Hz, {summary['bytes'] / 1e6:.1f} MB", markup=False)
    c.print(f"station: {summary['station']}  embodiment: {summary['embodiment']}  "
            f"streams: {', '.join(summary['streams']) or 'none'}", markup=False)
    table(None, ("episode", "steps", "seconds", "instruction", "cameras", "note"),
          [(e["index"], e.get("length"), f"{e.get('duration_s', 0):.2f}", e.get("instruction") or "",
            ", ".join(f"{k} {v.get('frames')}f@{v.get('rate')}" for k, v in e.get("cameras", {}).items()),
            "repaired" if e.get("repaired") else "") for e in ds.episodes])
    for p in summary["partial"]:
        warn(f"{p}: an interrupted episode; run `rio datasets repair {dataset}`")
    if summary["discarded"]:
        c.print(f"{summary['discarded']} discarded episodes kept in .discarded/ (delete them to free space)",
                markup=False)
    if verify:
        if damaged:
            for name, bad in damaged.items():
                warn(f"{name}: {'; '.join(bad)}")
            raise typer.Exit(1)
        c.print("verified: every file matches its recorded sha256", markup=False)


@app.command("repair")
def repair(dataset: Annotated[str, typer.Argument(help="Native RIO dataset directory.")]) -> None:
    """Finish episodes interrupted by a crash (or remove unrecoverable ones) and rebuild the index.
    Finished episodes are never modified."""
    from ..recording import repair_dataset
    from .output import console, warn

    report = repair_dataset(dataset)
    c = console()
    for line in report.repaired:
        c.print(f"repaired {line}", markup=False)
    for line in report.removed:
        c.print(f"removed {line}", markup=False)
    for line in report.index_notes:
        c.print(f"index: {line}", markup=False)
    for line in report.damaged:
        warn(f"damaged (left as is): {line}")
    if not report.changed:
        c.print("nothing to repair", markup=False)


@app.command("import")
def import_(
    src: Annotated[str, typer.Argument(help="Dataset in another format.")],
    out: Annotated[str, typer.Argument(help="Native RIO dataset directory to write.")],
    fmt: Annotated[str, typer.Option("--format", "-f", help="Its format (see `rio datasets formats`).")],
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
    result = run_with_progress(f"import {fmt}", lambda p: f.import_(Path(src), Path(out), progress=p))
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
