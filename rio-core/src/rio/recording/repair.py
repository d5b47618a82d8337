"""`rio datasets repair`: finish what a crash left behind and rebuild damaged metadata; never
modifies a finished episode's data and never deletes recorded data.

For each `episode_N.partial` directory: keep the longest consistent prefix (whole step records,
whole frame records, frames the video can actually decode, steps whose frames all exist) and seal it
as a finished episode marked `"repaired": true`. A camera stream with no decodable frame at all
(e.g. the encoder was killed with the recorder and its video holds only headers) does not cost the
steps: they are kept as a state-only episode, that stream's frames marked missing (-1, listed under
`"missing_streams"`). A partial that yields no usable step at all is moved to `DATASET/.quarantine/`
(only one holding no recorded byte, e.g. killed right after it started, is removed).

A finished episode whose episode.json is missing or damaged gets it rebuilt from its data files (the
old one is moved to .quarantine/); one whose steps.json is damaged too cannot be read and is moved to
.quarantine/ whole. A damaged dataset.json is moved there and the index rebuilt from the episode
directories (an episode finished just before a crash may also be missing from it). Video files the
encoder process closed properly (it does, when only the recorder was killed) are kept byte for byte;
a torn one is re-encoded from its decodable frames. Finished episodes whose files fail their sha256
are reported as damaged and left as they are.
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

from rio.errors import RioError
from rio.machine import host
from rio.machine.confine import OutsideRoot, inside
from rio.recording import index as I
from rio.recording import paths as L
from rio.recording.dataset import episode_problems, load_schema
from rio.recording.durable import fsync_file, move_aside, read_json
from rio.recording.episode_writer import FRAME_RECORD, estimate_rate, seal
from rio.recording.flatten import StepSchema
from rio.recording.video import StreamWriter, VideoOptions, read_frames


@dataclass
class RepairReport:
    repaired: list[str] = field(default_factory=list)
    removed: list[str] = field(default_factory=list)  # only directories that held no recorded byte
    quarantined: list[str] = field(default_factory=list)  # moved to DATASET/.quarantine/, never deleted
    index_notes: list[str] = field(default_factory=list)
    damaged: list[str] = field(default_factory=list)  # finished episodes whose files changed (left alone)
    details: list[str] = field(default_factory=list)

    @property
    def changed(self) -> bool:
        return bool(self.repaired or self.removed or self.quarantined or self.index_notes)


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


def _holds_data(path: Path) -> bool:
    """Whether an episode directory holds any recorded byte (recording.json is only the recorder's
    intent, written before the first step)."""
    return any(f.is_file() and f.name != L.RECORDING and f.stat().st_size > 0 for f in path.iterdir())


def set_aside(root: Path, path: Path, why: str, report: RepairReport) -> None:
    """An episode directory repair cannot use: moved to .quarantine/ (removed only if it holds no data)."""
    if not _holds_data(path):
        shutil.rmtree(path)
        report.removed.append(f"{path.name}: {why} (it held no recorded data)")
        return
    dest = move_aside(path, root / L.QUARANTINE)
    report.quarantined.append(f"{path.name}: {why}; moved to {L.QUARANTINE}/{dest.name}")


def _recording_info(path: Path) -> dict[str, Any]:
    """recording.json, or {} when it is missing or damaged (its facts are then estimated)."""
    try:
        rec = read_json(path / L.RECORDING)
    except RioError:
        return {}
    return rec if isinstance(rec, dict) else {}


def _mark_missing(steps_path: Path, schema: StepSchema, n_steps: int, columns: list[str]) -> None:
    """Rewrite the step records with these camera columns set to -1 (no frame): the steps stay, the
    frames they saw are marked missing. Written to a temporary file and renamed: never half done."""
    data = np.fromfile(steps_path, schema.dtype, count=n_steps)
    for col in columns:
        data[col] = -1
    tmp = steps_path.with_name(steps_path.name + ".repair")
    data.tofile(tmp)
    fsync_file(tmp)
    os.replace(tmp, steps_path)


def repair_partial(root: Path, path: Path, index: int, report: RepairReport) -> None:
    name = path.name
    schema_path, steps_path = path / L.STEPS_SCHEMA, path / L.STEPS
    if not schema_path.exists() or not steps_path.exists() or steps_path.stat().st_size == 0:
        set_aside(root, path, "no complete step was recorded", report)
        return
    try:
        schema = load_schema(path)
    except RioError as e:
        set_aside(root, path, f"its steps cannot be read ({e})", report)
        return
    rec = _recording_info(path)
    n_steps = steps_path.stat().st_size // schema.dtype.itemsize
    if n_steps == 0:
        set_aside(root, path, "no complete step was recorded", report)
        return
    video = VideoOptions(**rec["video"]) if isinstance(rec.get("video"), dict) else VideoOptions()
    fps = float(rec.get("fps") or 0) or None
    streams: dict[str, Any] = {}
    missing: list[str] = []
    notes: list[str] = []
    for cam, kinds in schema.cameras.items():
        for kind in kinds:
            key = L.stream_key(cam, kind)
            try:  # the camera's name comes from steps.json: its files must stay in the episode
                vfile = inside(path, L.video_file(cam, kind), source=schema_path, field=f"cameras[{cam!r}]")
                ffile = inside(path, L.frames_file(cam, kind), source=schema_path, field=f"cameras[{cam!r}]")
            except OutsideRoot as e:
                set_aside(root, path, f"its step layout names a camera outside the episode ({e})", report)
                return
            logged = ffile.stat().st_size // FRAME_RECORD.itemsize if ffile.exists() else 0
            if not vfile.exists() or logged == 0:
                decodable, clean, shape = 0, True, None
            else:
                decodable, clean, shape = _count_decodable(vfile, kind)
            n = min(logged, decodable)
            if n == 0:
                if logged:  # frames were recorded but none can be decoded: keep the steps, mark them missing
                    missing.append(key)
                    notes.append(f"{key}: no decodable frame; its frames are marked missing (state-only)")
                continue  # the undecodable files stay in the directory, untouched and unlisted
            if ffile.exists():
                _truncate(ffile, n * FRAME_RECORD.itemsize)
            stamps = np.fromfile(ffile, FRAME_RECORD)["t"]
            rate = estimate_rate(list(stamps[:8]), fps or 30.0)
            if not clean or decodable > n:
                _reencode(vfile, kind, n, rate, video)
                notes.append(f"{key}: re-encoded {n} decodable frames" + ("" if clean else " (the file was torn)"))
            assert shape is not None  # read from the decodable frames
            streams[key] = {"camera": cam, "kind": kind, "file": vfile.name, "frames_file": ffile.name,
                            "frames": n, "height": shape[0], "width": shape[1], "rate": rate,
                            "codec": "ffv1" if kind == "depth" else video.codec, "dropped": 0}
            if kind == "depth":
                streams[key]["depth_unit_m"] = video.depth_unit_m
    # the longest prefix of steps whose every (not missing) camera frame exists
    data = np.fromfile(steps_path, schema.dtype, count=n_steps)
    ok = np.ones(n_steps, bool)
    for key, info in streams.items():
        ok &= data[f"cam.{key}"] < info["frames"]  # a lost stream ends the episode where it was lost
    keep = int(np.argmin(ok)) if not ok.all() else n_steps
    if keep == 0:
        set_aside(root, path, "no step with all its camera frames survived", report)
        return
    _truncate(steps_path, keep * schema.dtype.itemsize)
    if missing:
        _mark_missing(steps_path, schema, keep, [f"cam.{key}" for key in missing])
    instruction = _trim_events(path / L.EVENTS, keep, rec.get("instruction"))
    t = data["t"][:keep]
    ep_fps = fps or (estimate_rate(list(t[:50]), 30.0) if keep > 1 else 30.0)
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
    if missing:
        meta["missing_streams"] = missing
    seal(root, path, meta)
    report.repaired.append(f"{name} -> {meta['dir']}: {keep} of {n_steps} steps" + (f"; {'; '.join(notes)}"
                                                                                     if notes else ""))


def _trim_events(events: Path, keep: int, instruction: str | None) -> str | None:
    """Keep the whole event lines about the first `keep` steps; returns the episode's instruction
    (`instruction`, else the first one the events set)."""
    lines = []
    if events.exists():
        for line in events.read_text(errors="replace").splitlines():
            try:
                e = json.loads(line)
            except json.JSONDecodeError:
                break
            if isinstance(e, dict) and e.get("step", 0) < keep:
                lines.append(line)
                if instruction is None and "instruction" in e:
                    instruction = e["instruction"]
    events.write_text("".join(x + "\n" for x in lines))
    fsync_file(events)
    return instruction


def rebuild_episode_meta(root: Path, path: Path, index: int, report: RepairReport) -> None:
    """A finished episode whose episode.json is missing or damaged: the damaged file is moved to
    .quarantine/ and the metadata rebuilt from the data files (as for an interrupted episode)."""
    meta_path = path / L.EPISODE_META
    problem = "missing"
    if meta_path.exists():
        try:
            I.load_episode_meta(path)
            return
        except RioError as e:
            problem = str(e)
        dest = move_aside(meta_path, root / L.QUARANTINE, f"{path.name}.{L.EPISODE_META}")
        report.quarantined.append(f"{path.name}/{L.EPISODE_META}: {problem}; moved to {L.QUARANTINE}/{dest.name}")
    before = len(report.repaired)
    repair_partial(root, path, index, report)
    if len(report.repaired) > before:
        report.repaired[-1] += f" (its {L.EPISODE_META} was {'missing' if problem == 'missing' else 'damaged'}; " \
                               "rebuilt from its data files)"


def _salvage_index(root: Path, report: RepairReport) -> None:
    """A damaged dataset.json is moved to .quarantine/ (the index is then rebuilt from the episodes)."""
    path = root / L.INDEX
    if not path.exists():
        return
    try:
        I.load(root)
    except RioError as e:
        dest = move_aside(path, root / L.QUARANTINE)
        report.quarantined.append(f"{L.INDEX}: {e}; moved to {L.QUARANTINE}/{dest.name}")


def repair_dataset(root: str | os.PathLike, *, verify: bool = True) -> RepairReport:
    """Repair the dataset at `root` (see the module docstring). Refuses while a recorder holds it."""
    from rio.recording.recorder import RecordingError

    root = Path(root)
    if not root.is_dir():
        raise RecordingError(f"no dataset at {root}")
    fd = os.open(root / L.LOCK, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        if not host.try_lock(fd):
            raise RecordingError(f"a recorder is still writing {root}; stop it before repairing")
        report = RepairReport()
        _salvage_index(root, report)
        finished = set()
        for idx, (path, partial) in sorted(L.scan(root).items()):
            if partial:
                repair_partial(root, path, idx, report)
            else:
                rebuild_episode_meta(root, path, idx, report)
                finished.add(idx)
        for p in sorted(root.iterdir()):  # a partial whose index is also finished (a user's copy): set aside
            parsed = L.parse_episode_dir(p.name)
            if parsed and parsed[1] and parsed[0] in finished:
                dest = move_aside(p, root / L.DISCARDED)
                report.quarantined.append(f"{p.name}: episode {parsed[0]} is already finished; moved to "
                                          f"{L.DISCARDED}/{dest.name}")
        index, notes = I.rebuild(root, salvage=True)
        report.index_notes = notes
        I.save(root, index)
        if verify:
            for e in index["episodes"]:
                bad = episode_problems(root / e["dir"])
                if bad:
                    report.damaged.append(f"{e['dir']}: " + "; ".join(bad))
        return report
    finally:
        os.close(fd)
