"""Recorder: every `Step` of a control loop into a crash-safe native dataset (see `paths`).

    with Recorder("datasets/pick", env=env, episodes=10) as rec:
        while not rec.done:
            ...                     # run one demonstration: rec.add(env.step(action)) every cycle
            rec.keep()              # or rec.discard() / rec.rerecord()

`add` costs one fixed-size write plus one memcpy per new camera frame: video encoding runs in a
separate, lower-priority process, so it never blocks the control loop, and `keep` (flush the
encoders, fsync, rename, rewrite the index) takes well under a second. One recorder at a time may
write a dataset (an flock on DATASET/.lock, released even if the process is killed).

Disk space is checked before each episode starts and about once a second while recording
(`free_bytes`). Below `min_free_bytes` the episode in progress is kept (finishing it needs a little
space, hence the margin) and `DiskFull` raised; if a write fails for lack of space (ENOSPC), the
episode is left as `episode_N.partial` for `rio datasets repair`. Either way: one error naming the
dataset and the space left, never a chain of tracebacks, and nothing already written is lost.
"""

from __future__ import annotations

import os
import shutil
import threading
import time
from pathlib import Path
from typing import Any

from rio.env import environment_names
from rio.errors import RioError
from rio.machine import host
from rio.recording import index as I
from rio.recording import paths as L
from rio.recording.durable import DISK_FULL_ERRNOS
from rio.recording.encoder import EncoderProcess
from rio.recording.episode_writer import EpisodeWriter
from rio.recording.video import VideoOptions, video_problem

#: free space below which no episode starts and one in progress is ended (kept while it still can be)
MIN_FREE_BYTES = 64 << 20


class RecordingError(RioError):
    pass


class DiskFull(RecordingError):
    """The dataset's disk is (nearly) full: recording stopped, what was written is kept or repairable."""


def free_bytes(path: str | os.PathLike) -> int:
    """Free space for the dataset at `path` (the probe the recorder checks; tests replace it)."""
    return shutil.disk_usage(path).free


def station_depth(station: Any) -> bool:
    """Whether a `rio.station.Station` has a camera publishing depth (its config's `depth`; a camera whose
    config has no such field is taken to have depth, so its encoder is checked before the first episode)."""
    from rio.station.roles import kind_of

    return any(kind_of(role) == "camera" and bool(getattr(c.config, "depth", True))
               for role, c in station.components.items())


def env_depth(env: Any) -> bool | None:
    """Whether a camera of `env` (a `rio.env.Env`) publishes depth: its connected clients' samples say so.
    One not yet connected (`with env:`) cannot tell, so a camera is taken to have depth (its encoder is
    checked); None for an object without cameras at all."""
    if getattr(env, "camera_clients", None) is None:
        return None
    clients = getattr(env, "cameras", None) or {}
    if not clients:
        return bool(env.camera_clients)

    def publishes_depth(client: Any) -> bool:
        ring = getattr(client, "ring_buffer", None)
        return ring is None or "depth" in ring.layout.names

    return any(publishes_depth(c) for c in clients.values())


def _size(n: int) -> str:
    return f"{n / 1e6:.1f} MB" if n < 10**9 else f"{n / 1e9:.2f} GB"


def _disk_full(err: BaseException) -> bool:
    return isinstance(err, OSError) and err.errno in DISK_FULL_ERRNOS


#: The roles whose drivers say what robot a dataset was recorded on (LeRobot's `robot_type`).
ROBOT_ROLES = ("arm", "arm2", "humanoid")


def robot_type_of(drivers: dict[str, str]) -> str | None:
    """The station's arm (or humanoid) driver name (`so101.follower`), two different arms joined with
    `+`; None for a station without one."""
    names = list(dict.fromkeys(drivers[r] for r in ROBOT_ROLES if drivers.get(r)))
    return "+".join(names) or None


def configured_camera_rates(env: Any) -> dict[str, float]:
    """{camera: the rate its driver is configured to publish at (`rate_hz`)}: what a stream's video is
    encoded at, rather than a rate guessed from its first frames' timestamps (the measured rate is
    recorded beside it, `measured_rate`)."""
    out = {}
    for name, factory in (getattr(env, "camera_clients", None) or {}).items():
        rate = getattr(getattr(factory, "config", None), "rate_hz", None)
        if isinstance(rate, (int, float)) and rate > 0:
            out[name] = float(rate)
    return out


class Recorder:
    def __init__(self, root: str | os.PathLike, *, fps: float | None = None, env: Any = None,
                 video: VideoOptions | dict | str | None = None, camera_fps: float | dict[str, float] | None = None,
                 episodes: int | None = None, instruction: str | None = None, metadata: dict | None = None,
                 station: str | None = None, on_exit: str = "keep", keep_discarded: bool = True,
                 buffer_frames: int = 60, encoder_nice: int = 10, cameras: bool | None = None,
                 depth: bool | None = None, min_free_bytes: int = MIN_FREE_BYTES):
        """
        root:        dataset directory (created if missing; new episodes are appended)
        fps:         the control rate the steps arrive at (default: `env.rate_hz`)
        env:         optional `rio.env.Env`: supplies fps, station, embodiment and action names
        video:       VideoOptions, a dict of them, or a codec name ("h264", "av1")
        camera_fps:  nominal camera rate(s) (default: each camera's configured `rate_hz` when `env` is a
                     station's, else estimated from the frames' timestamps)
        episodes:    how many episodes to keep this session (`done`/`remaining` count towards it)
        on_exit:     what leaving the `with` block does to an episode in progress: "keep" or "discard"
        cameras:     whether camera streams will be recorded (default: whether `env` has cameras); when
                     true, `open()` refuses if they could not be encoded (PyAV or its encoder missing)
        depth:       whether depth streams will be (their lossless encoder, FFV1, is then required too);
                     default: whether a camera of `env` publishes depth (`station_depth` for a Station),
                     else as `cameras`
        min_free_bytes: free disk space below which recording stops (DiskFull), keeping what was written
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
        self.min_free_bytes = int(min_free_bytes)
        self._space_every = max(1, round(self.fps))  # steps between free-space checks (about a second)
        self.info: dict[str, Any] = {"station": station}
        self.action_dim: int | None = None
        if cameras is None and env is not None:
            cameras = bool(getattr(env, "camera_clients", None))
        self.cameras = bool(cameras)
        if depth is None:
            depth = env_depth(env)
        self.depth = self.cameras and (True if depth is None else bool(depth))
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
        """Take station, embodiment and action names from an Env (before the first `add`), and the names of
        its environment state: the object poses of every sensor that names its objects (a simulator's
        world: `object_names()`, rows of its `object_poses`), as `environment_state`, {column: element
        names} (`cube.x`, ..., `cube.qz`), which exporters turn into `observation.environment_state`."""
        self.info["station"] = self.info.get("station") or getattr(env, "station", None)
        state = {f"meta.sensors.{name}.object_poses": names
                 for name, names in environment_names(getattr(env, "sensors", None) or {}).items()}
        if state:
            self.info["environment_state"] = state
        robot_type = robot_type_of(getattr(env, "drivers", None) or {})
        if robot_type:
            self.info["robot_type"] = robot_type
        if self.camera_fps is None and (rates := configured_camera_rates(env)):
            self.camera_fps = rates
        robot = getattr(env, "robot", None)
        if robot is not None:
            self.info["embodiment"] = robot.name
            layout = robot.action_parts()
            self.info["action_parts"] = [[label, n] for label, n in layout]
            # an embodiment names them from its drivers; a stand-in robot without the methods: numbered
            numbered = [f"{label}.{i}" if n > 1 else label for label, n in layout for i in range(n)]
            self.info["action_names"] = list(robot.action_names()) if hasattr(robot, "action_names") else numbered
            if hasattr(robot, "observation_names"):
                self.info["observation_names"] = {k: list(v) for k, v in robot.observation_names().items()}
            self.action_dim = sum(n for _, n in layout)
        elif getattr(env, "embodiment_cls", None) is not None:
            self.info["embodiment"] = env.embodiment_cls.name

    # -- lifecycle ----------------------------------------------------------------------------------
    def open(self) -> Recorder:
        if self.encoder is not None:
            return self
        if self.cameras and (why := video_problem(self.video, depth=self.depth)) is not None:
            raise RecordingError(f"cannot record the station's cameras: {why}")
        try:
            self.root.mkdir(parents=True, exist_ok=True)
            fd = os.open(self.root / L.LOCK, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as e:  # a path that cannot hold a dataset (a file on the way, /proc, no permission)
            raise RecordingError(f"{self.root}: cannot record here ({e.strerror or e})") from None
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
                        self._keep_or_leave(ended_by=f"recorder closed ({reason})" if reason else "recorder closed")
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
        """Never reuses a number, not even a discarded or quarantined episode's (its copy keeps it)."""
        assert self.index is not None  # read by open()
        used = set(L.scan(self.root)) | {e["index"] for e in self.index["episodes"]}
        for aside in (self.root / L.DISCARDED, self.root / L.QUARANTINE):
            if aside.is_dir():
                used |= {k for k in (L.set_aside_index(d.name) for d in aside.iterdir()) if k is not None}
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
            free = free_bytes(self.root)
            if free < self.min_free_bytes:
                raise DiskFull(f"{self.root}: not starting an episode: {_size(free)} free on its disk, the recorder "
                               f"needs {_size(self.min_free_bytes)}; free some space")
            try:
                self.writer = EpisodeWriter(
                    self.root, self.next_index(), self.encoder, fps=self.fps, video=self.video,
                    camera_fps=self.camera_fps, instruction=instruction or self.instruction, info=self.info,
                    action_dim=self.action_dim, buffer_frames=self.buffer_frames)
            except OSError as e:
                if not _disk_full(e):
                    raise
                raise DiskFull(f"{self.root}: not starting an episode: the disk is full "
                               f"({_size(free_bytes(self.root))} free); free some space") from None
            self._episode_metadata = {**self.metadata, **(metadata or {})}
            return self.writer.index

    def add(self, step: Any) -> None:
        """Record one Step (starting an episode if none is in progress). Never waits on encoding."""
        with self._mutex:
            if self.writer is None:
                self.start_episode()
            assert self.writer is not None  # made by start_episode()
            try:
                self.writer.add(step)
            except OSError as e:
                if not _disk_full(e):
                    raise
                self._stop_on_full_disk(keep=False)
            if self.writer.length % self._space_every == 0 and free_bytes(self.root) < self.min_free_bytes:
                self._stop_on_full_disk(keep=True)

    def _stop_on_full_disk(self, keep: bool) -> None:
        """End the episode in progress because the disk is (nearly) full, and raise DiskFull saying
        where it is: kept if `keep` and finishing it still fits, else left `.partial` for repair."""
        assert self.writer is not None
        index, steps = self.writer.index, self.writer.length
        where = self._keep_or_leave("disk almost full") if keep else self._leave_partial()
        raise DiskFull(f"{self.root}: the disk is full ({_size(free_bytes(self.root))} free, the recorder needs "
                       f"{_size(self.min_free_bytes)}): recording stopped; episode {index} ({steps} steps) {where}"
                       ) from None  # the OSError (ENOSPC) it replaces says less: no chained traceback

    def _keep_or_leave(self, ended_by: str) -> str:
        """keep() the episode in progress; if the disk fills while finishing it, leave it for repair
        and raise DiskFull (not the OSError). Returns where the episode is, in words."""
        assert self.writer is not None
        w = self.writer
        try:
            meta = self.keep(ended_by=ended_by)
        except OSError as e:
            if not _disk_full(e):
                raise
            self.writer = w
            raise DiskFull(f"{self.root}: the disk filled up while finishing episode {w.index} "
                           f"({_size(free_bytes(self.root))} free): it {self._leave_partial()}") from None
        return f"was kept as {meta['dir']}" if meta else "had no step and was dropped"

    def _leave_partial(self) -> str:
        """Leave the episode in progress as its .partial directory (repairable); where it is, in words."""
        assert self.writer is not None
        w, self.writer = self.writer, None
        path = w.leave_partial()
        if not path.name.endswith(L.PARTIAL_SUFFIX):  # the disk filled after it was sealed: only the index is behind
            return f"was kept as {L.episode_dir_name(w.index)}; `rio datasets repair {self.root}` updates the index"
        return f"was left as {path.name}: free some space, then run `rio datasets repair {self.root}`"

    def annotate(self, **metadata: Any) -> None:
        """Add to the metadata of the episode in progress (kept in its episode.json under `metadata`: the
        control loop adds the task's verdict here); nothing without one."""
        with self._mutex:
            if self.writer is not None:
                self._episode_metadata.update(metadata)

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
