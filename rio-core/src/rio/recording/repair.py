"""`rio datasets repair`: finish what a crash left behind, never touching finished episodes.

For each `episode_N.partial` directory: keep the longest consistent prefix (whole step records,
whole frame records, frames the video can actually decode, steps whose frames all exist), seal it
as a finished episode marked `"repaired": true`, or remove it when nothing is recoverable. Then
rebuild the index from the finished directories (an episode finished just before a crash may be
missing from it). Video files the encoder process closed properly (it does, when only the
recorder was killed) are kept byte for byte; a torn one is re-encoded from its decodable frames.
"""

from __future__ import annotations

import json
import os
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import host
from . import index as I
from . import paths as L
from .dataset import Episode
from .durable import fsync_file
from .episode_writer import FRAME_RECORD, estimate_rate, seal
from .flatten import StepSchema
from .video import StreamWriter, VideoOptions, read_frames


@dataclass
class RepairReport:
    repaired: list[str] = field(default_factory=list)
    removed: list[str] = field(default_factory=list)
    index_notes: list[str] = field(default_factory=list)
    damaged: list[str] = field(default_factory=list)  # finished episodes whose files changed (left alone)
    details: list[str] = field(default_factory=list)

    @property
    def changed(self) -> bool:
        return bool(self.repaired or self.removed or self.index_notes)


def _truncate(path: Path, size: int) -> None:
    if path.stat().st_size != size:
        with open(path, "r+b") as f:
            f.truncate(size)
            os.fsync(f.fileno())


def _count_decodable(path: Path, kind: str) -> tuple[int, bool, tuple[int, int] | None]:
    """(frames decodable, whole file clean, (height, width) of the coded frames)."""
    n, shape = 0, None
    try:
        for frame in read_frames(path, kind):
            n += 1
            shape = frame.shape[:2]
        return n, True, shape
    except Exception:  # noqa: BLE001 - anything after the last good frame counts as torn
        return n, False, shape


def _reencode(path: Path, kind: str, n: int, rate: float, video: VideoOptions) -> None:
    tmp = path.with_name(path.name + ".repair")
    frames = read_frames(path, kind, tolerate_truncation=True)
    first = next(frames)
    w = StreamWriter(tmp, kind, first.shape[0], first.shape[1], rate, video)
    w.write(first)
    for k, frame in enumerate(frames, start=1):
        if k >= n:
            break
        w.write(frame)
    w.close()
    fsync_file(tmp)
    os.replace(tmp, path)


def repair_partial(root: Path, path: Path, index: int, report: RepairReport) -> None:
    name = path.name
    schema_path, steps_path = path / L.STEPS_SCHEMA, path / L.STEPS
    if not schema_path.exists() or not steps_path.exists() or steps_path.stat().st_size == 0:
        shutil.rmtree(path)
        report.removed.append(f"{name}: no complete step was recorded")
        return
    rec = json.loads((path / L.RECORDING).read_text()) if (path / L.RECORDING).exists() else {}
    schema = StepSchema.from_json(json.loads(schema_path.read_text()))
    n_steps = steps_path.stat().st_size // schema.dtype.itemsize
    video = VideoOptions(**rec["video"]) if "video" in rec else VideoOptions()
    fps = float(rec.get("fps") or 0) or None
    streams: dict[str, Any] = {}
    notes: list[str] = []
    for cam, kinds in schema.cameras.items():
        for kind in kinds:
            key, vfile, ffile = L.stream_key(cam, kind), path / L.video_file(cam, kind), path / L.frames_file(cam, kind)
            logged = ffile.stat().st_size // FRAME_RECORD.itemsize if ffile.exists() else 0
            if not vfile.exists() or logged == 0:
                decodable, clean, shape = 0, True, None
            else:
                decodable, clean, shape = _count_decodable(vfile, kind)
            n = min(logged, decodable)
            if ffile.exists():
                _truncate(ffile, n * FRAME_RECORD.itemsize)
            stamps = np.fromfile(ffile, FRAME_RECORD)["t"] if n else np.zeros(0)
            rate = estimate_rate(list(stamps[:8]), fps or 30.0)
            if n and (not clean or decodable > n):
                _reencode(vfile, kind, n, rate, video)
                notes.append(f"{key}: re-encoded {n} decodable frames" + ("" if clean else " (the file was torn)"))
            if n == 0:
                if vfile.exists():
                    vfile.unlink()
                if ffile.exists():
                    ffile.unlink()
                notes.append(f"{key}: no decodable frame; stream dropped")
                continue
            assert shape is not None  # read from the decodable frames
            streams[key] = {"camera": cam, "kind": kind, "file": vfile.name, "frames_file": ffile.name,
                            "frames": n, "height": shape[0], "width": shape[1], "rate": rate,
                            "codec": "ffv1" if kind == "depth" else video.codec, "dropped": 0}
            if kind == "depth":
                streams[key]["depth_unit_m"] = video.depth_unit_m
    # the longest prefix of steps whose every camera frame exists
    data = np.fromfile(steps_path, schema.dtype, count=n_steps)
    ok = np.ones(n_steps, bool)
    for cam, kinds in schema.cameras.items():
        for kind in kinds:
            have = streams.get(L.stream_key(cam, kind), {}).get("frames", 0)
            ok &= data[f"cam.{cam}.{kind}"] < have  # a lost stream ends the episode where it was lost
    keep = int(np.argmin(ok)) if not ok.all() else n_steps
    if keep == 0:
        shutil.rmtree(path)
        report.removed.append(f"{name}: no step with all its camera frames survived")
        return
    _truncate(steps_path, keep * schema.dtype.itemsize)
    events = path / L.EVENTS
    if events.exists():
        lines = []
        for line in events.read_text().splitlines():
            try:
                e = json.loads(line)
            except json.JSONDecodeError:
                break
            if e.get("step", 0) < keep:
                lines.append(line)
        events.write_text("".join(x + "\n" for x in lines))
        fsync_file(events)
    else:
        events.write_text("")
    t = data["t"][:keep]
    ep_fps = fps or (estimate_rate(list(t[:50]), 30.0) if keep > 1 else 30.0)
    instruction = rec.get("instruction")
    for line in events.read_text().splitlines():
        e = json.loads(line)
        if "instruction" in e and instruction is None:
            instruction = e["instruction"]
    meta = {
        "format": L.FORMAT, "version": L.VERSION, "index": index, "dir": L.episode_dir_name(index),
        "length": keep, "fps": ep_fps, "measured_fps": round(float((keep - 1) / (t[-1] - t[0])), 3)
        if keep > 1 and t[-1] > t[0] else None, "t_start": float(t[0]), "t_end": float(t[-1]),
        "duration_s": round(float(t[-1] - t[0]) + 1.0 / ep_fps, 6), "instruction": instruction,
        **{k: v for k, v in rec.items() if k not in ("index", "fps", "instruction", "video", "started_at")},
        "observation_class": schema.observation_class, "streams": streams, "video": video.to_json(),
        "metadata": {}, "started_at": rec.get("started_at"), "finished_at": time.strftime("%Y-%m-%dT%H:%M:%S"),
        "ended_by": "repaired after an interrupted recording", "repaired": True,
        "warnings": [f"repaired: kept {keep} of {n_steps} steps"] + notes,
    }
    seal(root, path, meta)
    report.repaired.append(f"{name} -> {meta['dir']}: {keep} of {n_steps} steps" + (f"; {'; '.join(notes)}"
                                                                                     if notes else ""))


def repair_dataset(root: str | os.PathLike, *, verify: bool = True) -> RepairReport:
    """Repair the dataset at `root` (see the module docstring). Refuses while a recorder holds it."""
    from .recorder import RecordingError

    root = Path(root)
    if not root.is_dir():
        raise RecordingError(f"no dataset at {root}")
    fd = os.open(root / L.LOCK, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        if not host.try_lock(fd):
            raise RecordingError(f"a recorder is still writing {root}; stop it before repairing")
        report = RepairReport()
        finished = set()
        for idx, (path, partial) in sorted(L.scan(root).items()):
            if partial:
                repair_partial(root, path, idx, report)
            else:
                finished.add(idx)
        for p in root.iterdir():  # a partial whose index is also finished (a user's copy): set aside
            parsed = L.parse_episode_dir(p.name)
            if parsed and parsed[1] and parsed[0] in finished:
                trash = root / L.DISCARDED
                trash.mkdir(exist_ok=True)
                os.rename(p, trash / p.name)
                report.removed.append(f"{p.name}: episode {parsed[0]} is already finished; moved to {L.DISCARDED}/")
        index, notes = I.rebuild(root)
        report.index_notes = notes
        I.save(root, index)
        if verify:
            for e in index["episodes"]:
                bad = Episode(root / e["dir"]).verify()
                if bad:
                    report.damaged.append(f"{e['dir']}: " + "; ".join(bad))
        return report
    finally:
        os.close(fd)
