"""Recorder: every `Step` of a control loop into a crash-safe native dataset (see `paths`).

    with Recorder("datasets/pick", env=env, episodes=10) as rec:
        while not rec.done:
            ...                     # run one demonstration: rec.add(env.step(action)) every cycle
            rec.keep()              # or rec.discard() / rec.rerecord()

`add` costs one fixed-size write plus one memcpy per new camera frame: video encoding runs in a
separate, lower-priority process, so it never blocks the control loop, and `keep` (flush the
encoders, fsync, rename, rewrite the index) takes well under a second. One recorder at a time may
write a dataset (an flock on DATASET/.lock, released even if the process is killed).
"""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path
from typing import Any

from .. import host
from ..errors import RioError
from . import index as I
from . import paths as L
from .encoder import EncoderProcess
from .episode_writer import EpisodeWriter
from .video import VideoOptions, video_problem


class RecordingError(RioError):
    pass


class Recorder:
    def __init__(self, root: str | os.PathLike, *, fps: float | None = None, env: Any = None,
                 video: VideoOptions | dict | str | None = None, camera_fps: float | dict[str, float] | None = None,
                 episodes: int | None = None, instruction: str | None = None, metadata: dict | None = None,
                 station: str | None = None, on_exit: str = "keep", keep_discarded: bool = True,
                 buffer_frames: int = 60, encoder_nice: int = 10, cameras: bool | None = None):
        """
        root:        dataset directory (created if missing; new episodes are appended)
        fps:         the control rate the steps arrive at (default: `env.rate_hz`)
        env:         optional `rio.env.Env`: supplies fps, station, embodiment and action names
        video:       VideoOptions, a dict of them, or a codec name ("h264", "av1")
        camera_fps:  nominal camera rate(s) (default: estimated from the frames' timestamps)
        episodes:    how many episodes to keep this session (`done`/`remaining` count towards it)
        on_exit:     what leaving the `with` block does to an episode in progress: "keep" or "discard"
        cameras:     whether camera streams will be recorded (default: whether `env` has cameras); when
                     true, `open()` refuses if they could not be encoded (PyAV or its encoder missing)
        """
        self.root = Path(root)
        if fps is None and env is not None:
            fps = env.rate_hz
        if fps is None or not fps > 0:
            raise RecordingError("Recorder needs the control rate: pass fps= (or env=)")
        if on_exit not in ("keep", "discard"):
            raise ValueError("on_exit must be 'keep' or 'discard'")
        self.fps = float(fps)
        self.video = VideoOptions.from_any(video)
        self.video.encoder_options(30.0)  # validate the codec name now, not in the encoder process
        self.camera_fps, self.target, self.instruction = camera_fps, episodes, instruction
        self.metadata, self.on_exit, self.keep_discarded = dict(metadata or {}), on_exit, keep_discarded
        self.buffer_frames, self.encoder_nice = buffer_frames, encoder_nice
        self.info: dict[str, Any] = {"station": station}
        self.action_dim: int | None = None
        if cameras is None and env is not None:
            cameras = bool(getattr(env, "camera_clients", None))
        self.cameras = bool(cameras)
        if env is not None:
            self.describe_env(env)
        self.kept: list[dict[str, Any]] = []
        self.discarded = 0
        self.writer: EpisodeWriter | None = None
        self.encoder: EncoderProcess | None = None
        self.index: dict[str, Any] | None = None
        self._lock_fd: int | None = None
        self._mutex = threading.RLock()
        self.last_close_s: float | None = None

    def describe_env(self, env: Any) -> None:
        """Take station, embodiment and action names from an Env (before the first `add`)."""
        self.info["station"] = self.info.get("station") or getattr(env, "station", None)
        robot = getattr(env, "robot", None)
        if robot is not None:
            self.info["embodiment"] = robot.name
            layout = robot.action_parts()
            self.info["action_parts"] = [[label, n] for label, n in layout]
            self.info["action_names"] = [f"{label}.{i}" if n > 1 else label for label, n in layout for i in range(n)]
            self.action_dim = sum(n for _, n in layout)
        elif getattr(env, "embodiment_cls", None) is not None:
            self.info["embodiment"] = env.embodiment_cls.name

    # -- lifecycle ----------------------------------------------------------------------------------
    def open(self) -> Recorder:
        if self.encoder is not None:
            return self
        if self.cameras and (why := video_problem(self.video)) is not None:
            raise RecordingError(f"cannot record the station's cameras: {why}")
        self.root.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.root / L.LOCK, os.O_RDWR | os.O_CREAT, 0o644)
        if not host.try_lock(fd):
            os.close(fd)
            raise RecordingError(f"another recorder is writing {self.root} (it holds {self.root / L.LOCK})") from None
        self._lock_fd = fd
        self.index, notes = I.rebuild(self.root)  # picks up an episode finished just before a crash
        if notes or not (self.root / L.INDEX).exists():
            I.save(self.root, self.index)
        self.partials = [p.name for p, partial in L.scan(self.root).values() if partial]
        self.encoder = EncoderProcess(nice=self.encoder_nice)
        return self

    def __enter__(self) -> Recorder:
        return self.open()

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        self.close(None if exc_type is None else f"exception {exc_type.__name__}")

    def close(self, reason: str | None = None) -> None:
        """End the session: an episode in progress is kept or discarded per `on_exit`."""
        with self._mutex:
            try:
                if self.writer is not None:
                    if self.on_exit == "keep" and self.writer.length > 0:
                        self.keep(ended_by=f"recorder closed ({reason})" if reason else "recorder closed")
                    else:
                        self.discard()
            finally:
                if self.encoder is not None:
                    self.encoder.shutdown()
                    self.encoder = None
                if self._lock_fd is not None:
                    os.close(self._lock_fd)
                    self._lock_fd = None

    # -- episodes -----------------------------------------------------------------------------------
    def next_index(self) -> int:
        """Never reuses a number, not even a discarded episode's (its copy in .discarded/ keeps it)."""
        assert self.index is not None  # read by open()
        used = set(L.scan(self.root)) | {e["index"] for e in self.index["episodes"]}
        trash = self.root / L.DISCARDED
        if trash.is_dir():
            used |= {p[0] for p in (L.parse_episode_dir(d.name.split("-")[0]) for d in trash.iterdir()) if p}
        return max(used) + 1 if used else 0

    def start_episode(self, instruction: str | None = None, metadata: dict | None = None) -> int:
        """Begin a new episode (also done by the first `add`). Returns its index."""
        with self._mutex:
            if self.encoder is None:
                raise RecordingError("the recorder is not open: use `with Recorder(...) as rec:`")
            if self.writer is not None:
                raise RecordingError(f"episode {self.writer.index} is still recording: keep() or discard() it first")
            if self.done:
                raise RecordingError(f"all {self.target} episodes of this session are recorded")
            if not self.encoder.alive():
                raise RecordingError(f"the encoder process died ({self.encoder.exit_reason()}); close this recorder "
                                     "and start a new one")
            self.writer = EpisodeWriter(
                self.root, self.next_index(), self.encoder, fps=self.fps, video=self.video,
                camera_fps=self.camera_fps, instruction=instruction or self.instruction, info=self.info,
                action_dim=self.action_dim, buffer_frames=self.buffer_frames)
            self._episode_metadata = {**self.metadata, **(metadata or {})}
            return self.writer.index

    def add(self, step: Any) -> None:
        """Record one Step (starting an episode if none is in progress). Never waits on encoding."""
        with self._mutex:
            if self.writer is None:
                self.start_episode()
            assert self.writer is not None  # made by start_episode()
            self.writer.add(step)

    def keep(self, metadata: dict | None = None, *, ended_by: str = "keep") -> dict[str, Any] | None:
        """Finish the episode in progress: durable, renamed into place, indexed. Returns its
        metadata (None if it had no steps: an empty episode is dropped)."""
        with self._mutex:
            w = self.writer
            if w is None:
                return None
            t0 = time.perf_counter()
            if w.length == 0:
                self.writer = None
                w.abort(keep_copy=False)
                return None
            try:
                meta = w.finish(ended_by, {**self._episode_metadata, **(metadata or {})})
            finally:
                self.writer = None
            assert self.index is not None  # read by open(), before any episode started
            I.add_episode(self.index, meta)
            I.save(self.root, self.index)
            self.kept.append(meta)
            self.last_close_s = time.perf_counter() - t0
            return meta

    def discard(self) -> None:
        """Drop the episode in progress (moved to DATASET/.discarded/ unless keep_discarded=False)."""
        with self._mutex:
            w, self.writer = self.writer, None
            if w is not None:
                w.abort(keep_copy=self.keep_discarded)
                self.discarded += 1

    def rerecord(self) -> None:
        """Discard the episode in progress; the next `add` starts it again (same session count)."""
        self.discard()

    # -- bookkeeping --------------------------------------------------------------------------------
    @property
    def recording(self) -> bool:
        return self.writer is not None

    @property
    def steps(self) -> int:
        return 0 if self.writer is None else self.writer.length

    @property
    def episode_index(self) -> int | None:
        return None if self.writer is None else self.writer.index

    @property
    def remaining(self) -> int | None:
        return None if self.target is None else max(self.target - len(self.kept), 0)

    @property
    def done(self) -> bool:
        return self.target is not None and len(self.kept) >= self.target

    def status(self) -> str:
        """One line for a UI: 'episode 3/10 (index 7): 12.3 s, 369 steps, encoder backlog 0'."""
        n = len(self.kept) + (1 if self.writer else 0)
        of = f"/{self.target}" if self.target else ""
        if self.writer is None:
            return f"{len(self.kept)}{of} episodes kept, {self.discarded} discarded"
        backlog = self.encoder.backlog() if self.encoder else 0
        return (f"episode {n}{of} (index {self.writer.index}): {self.writer.duration_s:.1f} s, "
                f"{self.writer.length} steps, encoder backlog {backlog}")
