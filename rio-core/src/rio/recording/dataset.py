"""Reading a native RIO dataset: episodes as numpy columns, camera frames decoded on demand, and
`Step` objects rebuilt with their morphology observation class.

    ds = Dataset("datasets/pick")
    ep = ds.episode(0)
    ep.columns["action"]          # (T, action_dim), exactly as recorded
    for rgb in ep.step_frames("front"): ...   # one frame per step (the frame that step saw)

Reading refuses damaged data: before a file's contents are first used it is checked against the size
and sha256 its episode.json recorded, and a mismatch raises `DamagedEpisode` naming the episode and
file (an all-zero steps.bin must never reach an export or a robot as zero actions). `allow_damaged=True`
reads it anyway, with one `DamagedEpisodeWarning` per episode. Damaged metadata (dataset.json,
episode.json, steps.json) is a one-line ConfigError naming the file, and so is a name in it that points
outside the dataset (`rio.machine.confine`: an episode `dir`, a `files` key, a stream's file): such a
name is never followed, by any reader.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rio.errors import ConfigError, RioError
from rio.machine.confine import OutsideRoot, inside
from rio.recording import index as I
from rio.recording import paths as L
from rio.recording.checks import file_problems
from rio.recording.durable import read_json, sha256_file
from rio.recording.episode_writer import FRAME_RECORD
from rio.recording.flatten import StepSchema
from rio.recording.video import read_frames
from rio.schema import RENAMED_FIELDS, Camera, Step


class DatasetError(RioError):
    pass


class DamagedEpisode(DatasetError):
    """An episode's files differ from the sizes and sha256 its episode.json recorded."""

    def __init__(self, path: Path, problems: list[str]):
        self.path, self.problems = Path(path), list(problems)
        super().__init__(f"{self.path}: damaged episode: {'; '.join(self.problems)} (refused; "
                         "--allow-damaged / allow_damaged=True uses it anyway)")


class DamagedEpisodeWarning(UserWarning):
    """A damaged episode read anyway (allow_damaged=True)."""


@dataclass
class Verification:
    """What was checked of one episode's files (name -> problem or None), shared by the Episode
    objects one Dataset hands out, so a file is hashed once however often it is read."""

    results: dict[str, str | None] = field(default_factory=dict)
    warned: bool = False
    #: what `checks.file_problems` found (None: not checked yet)
    consistency: list[str] | None = None


def load_schema(path: Path) -> StepSchema:
    """An episode directory's steps.json, its observation columns under today's names (`current_names`);
    damaged is one ConfigError naming it."""
    schema_path = path / L.STEPS_SCHEMA
    raw = read_json(schema_path)
    try:
        return StepSchema.from_json(current_names(raw))
    except (KeyError, TypeError, ValueError) as e:
        raise ConfigError(f"{schema_path}: damaged (not a step layout: {type(e).__name__}: {e})") from None


def current_names(raw: dict[str, Any]) -> dict[str, Any]:
    """A steps.json layout with the observation columns renamed since it was recorded (`obs.gripper_position`
    -> `obs.gripper_width`: `rio.schema.RENAMED_FIELDS`) under their new names. The one place old names are
    read: every reader (steps, columns, replay, view, export, merge, repair) gets its layout here, and
    steps.bin's records are laid out by position, so the bytes read the same; the files are not changed."""
    renamed = {f"obs.{old}": f"obs.{new}" for old, new in RENAMED_FIELDS.items()}
    fields = raw["fields"]
    if not any(f[0] in renamed for f in fields):
        return raw
    return {**raw, "fields": [[renamed.get(f[0], f[0]), *f[1:]] for f in fields]}


class Episode:
    def __init__(self, path: Path, meta: dict[str, Any] | None = None, *, allow_damaged: bool = False,
                 verification: Verification | None = None):
        self.path = Path(path)
        self.partial = self.path.name.endswith(L.PARTIAL_SUFFIX)
        if meta is None:
            if not (self.path / L.EPISODE_META).exists():
                raise DatasetError(f"{self.path} is not a finished episode (no {L.EPISODE_META}); "
                                   "run `rio datasets repair` on its dataset")
            meta = I.load_episode_meta(self.path)
        self.meta = meta
        self.schema = load_schema(self.path)
        self.allow_damaged = allow_damaged
        self.verification = verification or Verification()
        self._columns: np.ndarray | None = None

    @property
    def index(self) -> int:
        return int(self.meta["index"])

    @property
    def fps(self) -> float:
        return float(self.meta["fps"])

    @property
    def length(self) -> int:
        return int(self.meta["length"])

    def __len__(self) -> int:
        return self.length

    @property
    def instruction(self) -> str | None:
        return self.meta.get("instruction")

    @property
    def streams(self) -> dict[str, dict[str, Any]]:
        return self.meta.get("streams", {})

    @property
    def cameras(self) -> list[str]:
        return sorted({s["camera"] for s in self.streams.values()})

    @property
    def columns(self) -> np.ndarray:
        """All steps as one structured array (field names: see `rio.recording.flatten`)."""
        if self._columns is None:
            self.require_intact(L.STEPS_SCHEMA, L.STEPS)
            data = np.fromfile(self.path / L.STEPS, self.schema.dtype, count=self.length)
            if len(data) != self.length:
                raise DatasetError(f"{self.path / L.STEPS}: {len(data)} steps, episode.json says {self.length}")
            self._columns = data
        return self._columns

    def column(self, name: str) -> np.ndarray:
        return np.array(self.columns[name])

    def observation_columns(self) -> dict[str, np.ndarray]:
        """{field: (T, ...) array} for the numeric observation fields (proprio, proprio_eef, ...)."""
        return {n[4:]: self.column(n) for n in self.schema.names if n.startswith("obs.")}

    def events(self) -> list[dict[str, Any]]:
        out = []
        path = self.path / L.EVENTS
        if path.exists():
            self.require_intact(L.EVENTS)
            for line in path.read_text().splitlines():
                try:
                    out.append(json.loads(line))
                except json.JSONDecodeError:  # a torn last line of an interrupted episode
                    break
        return out

    def instructions(self) -> list[str | None]:
        """The instruction in force at every step."""
        out: list[str | None] = [None] * self.length
        changes = sorted((e["step"], e["instruction"]) for e in self.events() if "instruction" in e)
        for k, (start, text) in enumerate(changes):
            end = changes[k + 1][0] if k + 1 < len(changes) else self.length
            out[start:end] = [text] * max(end - start, 0)
        return out

    # -- camera streams -----------------------------------------------------------------------------
    def stream(self, camera: str, kind: str = "rgb") -> dict[str, Any]:
        key = L.stream_key(camera, kind)
        if key not in self.streams:
            raise DatasetError(f"episode {self.index} has no stream '{key}' (streams: {sorted(self.streams)})")
        return self.streams[key]

    def file(self, name: str, field: str) -> Path:
        """The path of file `name` that episode.json names in `field`, confined to the episode directory
        (`OutsideRoot`, naming episode.json and the field, if it points outside)."""
        return inside(self.path, name, source=self.path / L.EPISODE_META, field=field)

    def frame_times(self, camera: str, kind: str = "rgb") -> np.ndarray:
        """(N,) records (t: capture time, step: first step that saw the frame)."""
        info = self.stream(camera, kind)
        path = self.file(info["frames_file"], f"streams[{L.stream_key(camera, kind)!r}].frames_file")
        self.require_intact(info["frames_file"])
        return np.fromfile(path, FRAME_RECORD, count=info["frames"])

    def frames(self, camera: str, kind: str = "rgb") -> Iterator[np.ndarray]:
        """Every encoded frame of a stream, in order (depth: uint16 in `depth_unit_m` units)."""
        info = self.stream(camera, kind)
        path = self.file(info["file"], f"streams[{L.stream_key(camera, kind)!r}].file")
        self.require_intact(info["file"])
        yield from read_frames(path, kind, info["height"], info["width"])

    def step_frame_index(self, camera: str, kind: str = "rgb") -> np.ndarray:
        return self.column(f"cam.{camera}.{kind}")

    def step_frames(self, camera: str, kind: str = "rgb") -> Iterator[np.ndarray | None]:
        """One frame per step: the frame that step saw (repeated while the camera had nothing new)."""
        want = self.step_frame_index(camera, kind)
        frames = self.frames(camera, kind)
        have, current = -1, None
        for k in want:
            if k < 0:
                yield None
                continue
            while have < k:
                current = next(frames)
                have += 1
            yield current

    def depth_m(self, depth: np.ndarray, camera: str) -> np.ndarray:
        unit = self.stream(camera, "depth").get("depth_unit_m", 0.001)
        return depth.astype(np.float32) * np.float32(unit)

    def steps(self, images: bool = True) -> Iterator[Step]:
        """The episode as `Step`s (the recorded morphology observation, cameras decoded)."""
        cols = self.columns
        names = [(s["camera"], s["kind"]) for s in self.streams.values()] if images else []
        iters = {(c, k): self.step_frames(c, k) for c, k in names}
        instr = self.instructions()
        has_action = "action" in self.schema.names
        for i in range(self.length):
            rec = cols[i]
            cams: dict[str, Camera] = {}
            for (c, k), it in iters.items():
                frame = next(it)
                cam = cams.setdefault(c, Camera(meta={}))
                if k == "depth" and frame is not None:
                    frame = self.depth_m(frame, c)
                setattr(cam, k, frame)
            action = np.array(rec["action"]) if has_action else None
            meta = self.schema.meta(rec)
            meta.setdefault("t_obs", float(rec["t"]))
            yield Step(int(rec["timestep"]), self.schema.observation(rec, cams), instr[i], action, meta)

    # -- integrity ----------------------------------------------------------------------------------
    def file_problem(self, name: str) -> str | None:
        """Why file `name` differs from what episode.json recorded (None: intact, or not recorded)."""
        want = self.meta.get("files", {}).get(name)
        if not isinstance(want, dict):
            return None
        try:
            p = self.file(name, f"files[{name!r}]")
        except OutsideRoot as e:
            return str(e)
        if not p.exists():
            return f"{name}: missing"
        if p.stat().st_size != want.get("bytes") or sha256_file(p) != want.get("sha256"):
            return f"{name}: changed since it was recorded"
        return None

    def verify(self) -> list[str]:
        """Files whose size or sha256 differ from episode.json, and values of episode.json the files
        contradict (`checks.file_problems`); empty: the episode is intact."""
        return [bad for name in self.meta.get("files", {}) if (bad := self.file_problem(name))] + self.consistency()

    def consistency(self) -> list[str]:
        """`checks.file_problems`, once per Verification (steps, frames and videos against episode.json)."""
        if self.verification.consistency is None:
            self.verification.consistency = file_problems(self)
        return self.verification.consistency

    def require_intact(self, *names: str) -> None:
        """Refuse to read damaged data: files `names` (default: all of them) are checked once against
        episode.json; a mismatch raises DamagedEpisode naming them, or with `allow_damaged` warns once."""
        results = self.verification.results
        for name in names or tuple(self.meta.get("files", {})):
            if name not in results:
                results[name] = self.file_problem(name)
        bad = [p for n in (names or results) if (p := results.get(n))]
        if not bad:
            return
        if not self.allow_damaged:
            raise DamagedEpisode(self.path, bad)
        if not self.verification.warned:
            self.verification.warned = True
            warnings.warn(DamagedEpisodeWarning(f"{self.path}: damaged episode used anyway: {'; '.join(bad)}"),
                          stacklevel=2)

    def check(self) -> None:
        """`require_intact` for every file, and episode.json's values against the files (a length steps.bin
        does not hold, a "video" that is none): what export, replay and merge call before using an episode."""
        self.require_intact()
        bad = self.consistency()
        if not bad:
            return
        if not self.allow_damaged:
            raise DamagedEpisode(self.path, bad)
        if not self.verification.warned:
            self.verification.warned = True
            warnings.warn(DamagedEpisodeWarning(f"{self.path}: damaged episode used anyway: {'; '.join(bad)}"),
                          stacklevel=2)


def episode_problems(path: Path) -> list[str]:
    """What is wrong with a finished episode directory: its metadata cannot be read, or files differ
    from what episode.json recorded (empty: intact). Never raises, so a report covers every episode."""
    try:
        return Episode(path).verify()
    except RioError as e:
        return [str(e)]


class Dataset:
    """A native dataset directory (`dataset.json` + episode directories). Reading a damaged episode's
    data raises DamagedEpisode unless `allow_damaged` (see the module docstring)."""

    def __init__(self, root: str | Path, *, allow_damaged: bool = False):
        self.root = Path(root)
        self.allow_damaged = allow_damaged
        if not (self.root / L.INDEX).exists():
            if not self.root.is_dir():
                raise DatasetError(f"no dataset at {self.root}")
            if not any(L.scan(self.root)):
                raise DatasetError(f"{self.root} is not a RIO dataset (no {L.INDEX})")
        self.index = I.load(self.root)
        self._verification: dict[int, Verification] = {}

    @property
    def episodes(self) -> list[dict[str, Any]]:
        return self.index["episodes"]

    def __len__(self) -> int:
        return len(self.episodes)

    @property
    def fps(self) -> float | None:
        return self.index.get("fps")

    def episode_dir(self, entry: dict[str, Any]) -> Path:
        """An index entry's directory, confined to the dataset (`OutsideRoot` naming dataset.json and the
        entry otherwise: a downloaded index must not send readers elsewhere)."""
        pos = next((k for k, e in enumerate(self.episodes) if e is entry), entry.get("index"))
        return inside(self.root, entry["dir"], source=self.root / L.INDEX, field=f"episodes[{pos}].dir")

    def _open(self, entry: dict[str, Any]) -> Episode:
        v = self._verification.setdefault(entry["index"], Verification())
        return Episode(self.episode_dir(entry), allow_damaged=self.allow_damaged, verification=v)

    def episode(self, k: int) -> Episode:
        """Episode by its index (the number in its directory name)."""
        for e in self.episodes:
            if e["index"] == k:
                return self._open(e)
        raise DatasetError(f"{self.root}: no episode {k} (episodes: {[e['index'] for e in self.episodes]})")

    def __iter__(self) -> Iterator[Episode]:
        for e in self.episodes:
            yield self._open(e)

    def damaged(self) -> dict[str, list[str]]:
        """{episode directory: problems} for every indexed episode that is not intact (hashes every file)."""
        out = {}
        for e in self.episodes:
            try:
                path = self.episode_dir(e)
            except OutsideRoot as err:
                out[e["dir"]] = [str(err)]
                continue
            if bad := episode_problems(path):
                out[e["dir"]] = bad
        return out

    def _dir_or_none(self, entry: dict[str, Any]) -> Path | None:
        try:
            return self.episode_dir(entry)
        except OutsideRoot:
            return None

    def partials(self) -> list[Path]:
        return [p for p, partial in L.scan(self.root).values() if partial]

    def summary(self) -> dict[str, Any]:
        eps = self.episodes
        dirs = [d for e in eps if (d := self._dir_or_none(e)) is not None]
        size = sum(f.stat().st_size for d in dirs if d.is_dir() for f in d.iterdir()
                   if f.is_file() and not f.is_symlink())
        cams = sorted({k for e in eps for k in e.get("cameras", {})})
        return {"path": str(self.root), "episodes": len(eps), "steps": self.index.get("total_steps", 0),
                "fps": self.fps, "station": self.index.get("station"), "embodiment": self.index.get("embodiment"),
                "duration_s": round(sum(e.get("duration_s", 0.0) for e in eps), 3), "streams": cams,
                "bytes": size, "instructions": sorted({e["instruction"] for e in eps if e.get("instruction")}),
                "partial": [p.name for p in self.partials()],
                "discarded": len(list((self.root / L.DISCARDED).iterdir())) if (self.root / L.DISCARDED).is_dir()
                else 0}
