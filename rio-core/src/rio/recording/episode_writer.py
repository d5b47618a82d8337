"""Writes one episode into its `.partial` directory, then finishes it: fsync, rename, done.

Used by `Recorder` (one at a time). Steps are appended as fixed-size records as they arrive; each
new camera frame is copied once, from its camera node's ring straight into the encoder's shared-memory
ring (depth as the camera's integers: the encoder converts if its unit differs), and logged (capture
time, step) in its `*.frames.bin`. A camera's nominal rate is estimated from its first frames' timestamps
(unless given), so a 30 fps camera in a 100 Hz loop is stored as 30 fps video, not 100.
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

from rio import clock
from rio.errors import FrameGone
from rio.machine.confine import inside
from rio.recording import paths as L
from rio.recording.durable import AppendFile, describe_files, fsync_dir, move_aside, write_json_atomic
from rio.recording.encoder import EncoderProcess
from rio.recording.flatten import StepSchema, flat_meta
from rio.recording.video import VideoOptions, depth_units
from rio.schema import depth_meters

FRAME_RECORD = np.dtype([("t", "<f8"), ("step", "<i8")])
_RATE_SAMPLES = 4  # distinct frames used to estimate a camera's rate


def fill_slot(dest: np.ndarray, frame: np.ndarray, depth_scale: float | None, unit_m: float) -> float | None:
    """Copy one frame into an encoder ring slot (the one copy a recorded frame costs the control loop);
    returns the depth_scale the encoder is to read the slot in (None: meters, or not depth).

    A stream's ring holds what its first frame came as: a camera's depth in its own units (uint16, from
    a camera node's ring: copied as it is, the encoder turns it into the stored units) or in meters (a
    `Camera` made by hand). A later frame in the other form is converted on the way in (rare: its pixels
    were taken out of the ring first), with the arithmetic the encoder uses, so what is stored is the same."""
    if depth_scale is not None and dest.dtype.kind == "f":  # units into a meters ring
        np.copyto(dest, depth_meters(frame, depth_scale))
        return None
    if depth_scale is None and dest.dtype.kind == "u" and frame.dtype.kind == "f":  # meters into a units ring
        np.copyto(dest, depth_units(frame, unit_m))
        return unit_m
    np.copyto(dest, frame, casting="same_kind")
    return depth_scale


def estimate_rate(stamps: list[float], fallback: float) -> float:
    """Nominal frame rate from capture times; snapped to an integer when within 3 %."""
    d = np.diff(np.asarray(stamps, dtype=np.float64))
    d = d[d > 0]
    if d.size == 0:
        return float(fallback)
    rate = 1.0 / float(np.median(d))
    snapped = round(rate)
    return float(snapped) if snapped > 0 and abs(rate - snapped) <= 0.03 * rate else round(rate, 3)


@dataclass
class _Stream:
    key: str
    camera: str
    kind: str
    shape: tuple[int, ...]
    file: AppendFile
    rate: float | None = None
    count: int = 0
    dropped: int = 0
    last_ts: float | None = None
    opened: bool = False
    pending: list[tuple[int, float | None]] = field(default_factory=list)  # (slot, depth_scale) until opened
    stamps: list[float] = field(default_factory=list)
    intrinsics: list | None = None
    distortion: tuple[str, list] = ("none", [0.0] * 5)  # (model, coefficients) beside the intrinsics


class EpisodeWriter:
    def __init__(self, root: Path, index: int, encoder: EncoderProcess, *, fps: float, video: VideoOptions,
                 camera_fps: float | dict[str, float] | None = None, instruction: str | None = None,
                 info: dict[str, Any] | None = None, action_dim: int | None = None, buffer_frames: int = 60):
        self.root, self.index, self.encoder = root, index, encoder
        self.fps, self.video, self.camera_fps = float(fps), video, camera_fps
        self.info = dict(info or {})
        self.action_dim, self.buffer_frames = action_dim, buffer_frames
        self.dir = root / L.partial_dir_name(index)
        self.dir.mkdir()
        fsync_dir(root)
        self.schema: StepSchema | None = None
        self.steps: AppendFile | None = None
        self.events = AppendFile(self.dir / L.EVENTS)
        self.streams: dict[str, _Stream] = {}
        self.length = 0
        self.t_first: float | None = None
        self.t_last: float | None = None
        self.instruction = instruction
        self._last_instruction: str | None = None
        self._last_other: dict[str, Any] = {}
        self.warnings: list[str] = []
        self.started_at = time.strftime("%Y-%m-%dT%H:%M:%S")
        # what `rio datasets repair` needs to finish this episode if the recorder dies
        write_json_atomic(self.dir / L.RECORDING, {
            "index": index, "fps": self.fps, "instruction": instruction, **self.info, "video": video.to_json(),
            "started_at": self.started_at})
        if instruction is not None:
            self._event({"step": 0, "instruction": instruction})
            self._last_instruction = instruction

    # -- recording ----------------------------------------------------------------------------------
    def add(self, step: Any) -> None:
        t_recv = clock.now()
        meta = step.meta or {}
        t = float(meta.get("t_obs", t_recv))
        if self.schema is None:
            self._start(step)
        elif self.length < 3 and (extra := self.schema.unknown_fields(step)):
            self._warn(f"step {self.length}: fields not in the episode's layout are not stored: {extra}")
        assert self.schema is not None and self.steps is not None  # made by _start() at the first step
        i = self.length
        frames = self._frames(step, i, t)
        rec = self.schema.record(step, t, t_recv, frames)
        self.steps.write(rec.tobytes())
        self.length += 1
        self.t_first = t if self.t_first is None else self.t_first
        self.t_last = t
        if step.instruction is not None and step.instruction != self._last_instruction:
            self._last_instruction = step.instruction
            self.instruction = self.instruction or step.instruction
            self._event({"step": i, "instruction": step.instruction})
        other = flat_meta(meta)[1]
        changed = {k: v for k, v in other.items() if self._last_other.get(k, object()) != v}
        if changed:
            self._last_other.update(changed)
            self._event({"step": i, "meta": changed})

    def _start(self, step: Any) -> None:
        schema = StepSchema.from_step(step, self.action_dim)
        for cam, kinds in schema.cameras.items():  # a camera's name becomes file names: they stay in the episode
            for kind in kinds:
                for name in (L.video_file(cam, kind), L.frames_file(cam, kind)):
                    inside(self.dir, name, source=self.dir, field=f"camera {cam!r}")
        self.schema = schema
        write_json_atomic(self.dir / L.STEPS_SCHEMA, self.schema.to_json())
        self.steps = AppendFile(self.dir / L.STEPS)

    def _frames(self, step: Any, i: int, t: float) -> dict[str, int]:
        out: dict[str, int] = {}
        cams = step.observation.cameras or {}
        assert self.schema is not None  # made by _start() at the first step
        for cam, kinds in self.schema.cameras.items():
            c = cams.get(cam)
            ts = c.meta.get("timestamp") if c is not None and c.meta else None
            ts = None if ts is None else float(ts)
            new = []
            for kind in kinds:
                s = self.streams.get(L.stream_key(cam, kind))
                if c is None or (s is not None and ts is not None and s.count and ts == s.last_ts):
                    # no camera this step, or the same frame as last step: not encoded twice
                    out[f"cam.{cam}.{kind}"] = -1 if s is None else s.count - 1
                else:
                    new.append(kind)
            if new:
                self._camera_frames(cam, c, new, i, t if ts is None else ts, ts, out)
        return out

    def _camera_frames(self, cam: str, c: Any, kinds: list[str], i: int, t: float, ts: float | None,
                       out: dict[str, int]) -> None:
        """Copy a camera's new frame into the encoder's rings: once, straight from where its pixels are
        (`Camera.in_place`: a camera node's ring slot), committed only if the slot still held that frame
        after the copy; a frame overwritten meanwhile is dropped and counted, never stored torn."""
        staged: list[tuple[_Stream, int, float | None]] = []  # (stream, slot, the slot's depth_scale)
        settled: set[str] = set()  # kinds whose outcome (no pixels, dropped) is final whatever the check says
        try:
            with c.in_place() as px:
                for kind in kinds:
                    key, col = L.stream_key(cam, kind), f"cam.{cam}.{kind}"
                    arr = px.get(kind)
                    s = self.streams.get(key)
                    if arr is None:
                        out[col] = -1 if s is None else s.count - 1
                        settled.add(kind)
                        continue
                    if s is None:
                        s = self._stream(cam, kind, arr, c)
                    reserved = None
                    if tuple(arr.shape) != s.shape:
                        self._warn(f"{key}: frame shape changed from {s.shape} to {arr.shape}; frame dropped")
                    else:
                        reserved = self.encoder.reserve(key)
                    if reserved is None:  # a changed shape, or the encoder's ring full (it fell behind)
                        s.dropped += 1
                        out[col] = s.count - 1
                        settled.add(kind)
                        continue
                    slot, dest = reserved
                    scale = px.get("depth_scale") if kind == "depth" else None
                    staged.append((s, slot, fill_slot(dest, arr, scale, self.video.depth_unit_m)))
        except FrameGone:
            self._warn(f"{cam}: a frame was gone from its camera's ring before it was recorded (the step reached "
                       "the recorder more than a ring of frames after it was observed); dropped")
            for kind in kinds:
                if kind not in settled:
                    s = self.streams.get(L.stream_key(cam, kind))
                    if s is not None:
                        s.dropped += 1
                    out[f"cam.{cam}.{kind}"] = -1 if s is None else s.count - 1
            return
        for s, slot, scale in staged:
            self.encoder.commit(s.key)
            s.file.write(np.array((t, i), FRAME_RECORD).tobytes())
            s.count += 1
            s.last_ts = ts
            if s.opened:
                self.encoder.encode(s.key, slot, scale)
            else:
                s.pending.append((slot, scale))
                if ts is not None:
                    s.stamps.append(ts)
                if ts is None or len(s.stamps) >= _RATE_SAMPLES or len(s.pending) >= self.buffer_frames // 2:
                    self._open(s)
            out[f"cam.{s.camera}.{s.kind}"] = s.count - 1

    def _stream(self, cam: str, kind: str, arr: np.ndarray, c: Any) -> _Stream:
        key = L.stream_key(cam, kind)
        shape = tuple(arr.shape)
        dtype = np.uint8 if kind == "rgb" else arr.dtype
        self.encoder.ensure_ring(key, shape, np.dtype(dtype), self.buffer_frames)
        rate = self.camera_fps.get(cam) if isinstance(self.camera_fps, dict) else self.camera_fps
        meta = c.meta or {}
        k = meta.get("intrinsics")
        s = _Stream(key, cam, kind, shape, AppendFile(self.dir / L.frames_file(cam, kind)), rate=rate,
                    intrinsics=None if k is None else np.asarray(k).tolist())
        if "distortion" in meta:
            s.distortion = (str(meta.get("distortion_model", "none")), np.asarray(meta["distortion"], float).tolist())
        self.streams[key] = s
        return s

    def _open(self, s: _Stream) -> None:
        if s.rate is None:
            s.rate = estimate_rate(s.stamps, self.fps)
        h, w = s.shape[0], s.shape[1]
        self.encoder.open(s.key, self.dir / L.video_file(s.camera, s.kind), s.kind, h, w, s.rate, self.video)
        for slot, scale in s.pending:
            self.encoder.encode(s.key, slot, scale)
        s.pending.clear()
        s.opened = True

    def _event(self, obj: dict[str, Any]) -> None:
        self.events.write((json.dumps(obj, default=str) + "\n").encode())

    def _warn(self, text: str) -> None:
        if text not in self.warnings:
            self.warnings.append(text)
            if self.events.fd >= 0:  # after finish() closed the log, warnings go to episode.json only
                self._event({"step": self.length, "warning": text})

    # -- ending -------------------------------------------------------------------------------------
    @property
    def duration_s(self) -> float:
        if self.t_first is None or self.t_last is None:  # both are set at the first step
            return 0.0
        return self.t_last - self.t_first + 1.0 / self.fps

    def finish(self, ended_by: str = "keep", metadata: dict | None = None) -> dict[str, Any]:
        """Make the episode durable and final; returns its metadata (episode.json)."""
        assert self.schema is not None and self.steps is not None, "finish() needs at least one step"
        for s in self.streams.values():
            if not s.opened:
                self._open(s)
        results = self.encoder.close_streams(list(self.streams)) if self.streams else {}
        self.encoder.poll()
        for key, err in self.encoder.errors.items():
            if key in self.streams:
                results.setdefault(key, {})["error"] = err
        self.steps.close(sync=True)
        self.events.close(sync=True)
        streams: dict[str, Any] = {}
        for key, s in self.streams.items():
            s.file.close(sync=True)
            r = results.get(key, {})
            t = np.fromfile(s.file.path, FRAME_RECORD)["t"]
            info = {"camera": s.camera, "kind": s.kind, "file": L.video_file(s.camera, s.kind),
                    "frames_file": L.frames_file(s.camera, s.kind), "frames": int(r.get("frames", 0)),
                    "height": s.shape[0], "width": s.shape[1], "rate": s.rate,
                    "measured_rate": round(float((len(t) - 1) / (t[-1] - t[0])), 3) if len(t) > 1 and t[-1] > t[0]
                    else None, "dropped": s.dropped}
            info["codec"] = "ffv1" if s.kind == "depth" else self.video.codec
            if s.kind == "depth":
                info["depth_unit_m"] = self.video.depth_unit_m
            if s.intrinsics is not None:  # a camera that publishes no distortion is a pinhole camera: "none"
                info["intrinsics"] = s.intrinsics
                info["distortion_model"], info["distortion"] = s.distortion
            if r.get("error"):
                info["error"] = r["error"]
            if info["frames"] != s.count:
                self._warn(f"{key}: {s.count} frames logged but {info['frames']} encoded")
            if s.dropped:
                self._warn(f"{key}: {s.dropped} frames dropped (the encoder fell behind)")
            streams[key] = info
        ts = np.fromfile(self.dir / L.STEPS, self.schema.dtype)["t"]
        measured = float((len(ts) - 1) / (ts[-1] - ts[0])) if len(ts) > 1 and ts[-1] > ts[0] else None
        if measured is not None and abs(measured - self.fps) > 0.1 * self.fps:
            self._warn(f"steps arrived at {measured:.1f} Hz but the dataset declares {self.fps:g} Hz")
        meta = {
            "format": L.FORMAT, "version": L.VERSION, "index": self.index, "dir": L.episode_dir_name(self.index),
            "length": self.length, "fps": self.fps, "measured_fps": None if measured is None else round(measured, 3),
            "t_start": self.t_first, "t_end": self.t_last, "duration_s": round(self.duration_s, 6),
            "instruction": self.instruction, **self.info, "observation_class": self.schema.observation_class,
            "streams": streams, "video": self.video.to_json(), "metadata": metadata or {},
            "started_at": self.started_at, "finished_at": time.strftime("%Y-%m-%dT%H:%M:%S"),
            "ended_by": ended_by, "warnings": self.warnings,
        }
        self.dir = seal(self.root, self.dir, meta)
        return meta

    def abort(self, keep_copy: bool = True) -> Path | None:
        """Drop the episode: streams stopped, directory moved to .discarded/ (or deleted)."""
        if self.streams:
            try:
                self.encoder.abort_streams(list(self.streams))
            except Exception:  # noqa: BLE001 - discarding must not fail on a dead encoder
                pass
        for f in [self.steps, self.events, *(s.file for s in self.streams.values())]:
            if f is not None:
                f.close(sync=False)
        if not keep_copy or self.length == 0:
            shutil.rmtree(self.dir, ignore_errors=True)
            return None
        return move_aside(self.dir, self.root / L.DISCARDED, L.episode_dir_name(self.index))

    def leave_partial(self) -> Path:
        """Stop writing and leave the `.partial` directory as it is, for `rio datasets repair` (what the
        recorder does when the disk is full: finishing would need space there is not). Never raises."""
        if self.streams:
            try:
                self.encoder.abort_streams(list(self.streams))  # the encoder closes its files, deletes nothing
            except Exception:  # noqa: BLE001 - the episode is left for repair whatever the encoder does
                pass
        for f in [self.steps, self.events, *(s.file for s in self.streams.values())]:
            if f is not None:
                try:
                    f.close(sync=True)
                except OSError:
                    pass
        return self.dir


def seal(root: Path, partial: Path, meta: dict[str, Any]) -> Path:
    """Finish an episode directory: list its files with sizes and sha256 in episode.json (written
    and fsynced last), then rename `episode_N.partial` to `episode_N` and fsync the dataset
    directory. Until that rename the episode does not exist for readers."""
    names = [L.STEPS_SCHEMA, L.STEPS, L.EVENTS]
    for info in meta.get("streams", {}).values():
        names += [n for n in (info["frames_file"], info["file"]) if (partial / n).exists()]
    meta["files"] = describe_files(partial, names)
    write_json_atomic(partial / L.EPISODE_META, meta)
    final = root / L.episode_dir_name(meta["index"])
    os.rename(partial, final)
    fsync_dir(root)
    return final
