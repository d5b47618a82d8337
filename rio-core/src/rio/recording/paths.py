"""Where everything of a native RIO dataset lives: names and paths in one place, so the writer, the reader and
`rio datasets repair` can never disagree about where something lives.

    DATASET/
      dataset.json                  index of finished episodes (rewritten atomically)
      .lock                         held (flock) by the one recorder writing this dataset
      episode_000000/               a finished episode: never modified once renamed into place
        episode.json                its metadata, sizes and sha256 of every file (written last)
        recording.json              what the recorder knew at the start (fps, station, codec)
        steps.json                  the record layout of steps.bin (a numpy structured dtype)
        steps.bin                   one fixed-size little-endian record per Step, in order
        events.jsonl                what is not numeric: instruction and string meta changes
        front.rgb.mp4               a camera stream (H.264/AV1, fragmented MP4)
        front.rgb.frames.bin        per encoded frame: capture time, first step that saw it
        front.depth.mkv             depth in integer units (default 1 mm), FFV1, lossless
      episode_000001.partial/       the episode being recorded (or left by a crash: repair it)
      .discarded/                   discarded episodes, kept until the user deletes them
      .quarantine/                  what `rio datasets repair` could not use (unreadable metadata, an
                                    interrupted episode with no usable step): moved here, never deleted

A file appended while recording is only ever appended to, in whole records, so whatever a crash
leaves is a readable prefix; `rio datasets repair` turns it into a finished episode.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from rio.machine.confine import is_inside

FORMAT = "rio-dataset"
VERSION = 1

INDEX = "dataset.json"
LOCK = ".lock"
DISCARDED = ".discarded"
QUARANTINE = ".quarantine"
PARTIAL_SUFFIX = ".partial"

EPISODE_META = "episode.json"
STEPS_SCHEMA = "steps.json"
RECORDING = "recording.json"
STEPS = "steps.bin"
EVENTS = "events.jsonl"

_EPISODE_RE = re.compile(r"^episode_(\d{6,})(\.partial)?$")


def episode_dir_name(index: int) -> str:
    return f"episode_{index:06d}"


def partial_dir_name(index: int) -> str:
    return episode_dir_name(index) + PARTIAL_SUFFIX


def parse_episode_dir(name: str) -> tuple[int, bool] | None:
    """(index, is_partial) for an episode directory name, else None."""
    m = _EPISODE_RE.match(name)
    return (int(m.group(1)), m.group(2) is not None) if m else None


def set_aside_index(name: str) -> int | None:
    """The episode index of an entry of .discarded/ or .quarantine/ ('episode_000003.partial-20240101-120000'),
    so a new episode never reuses its number."""
    parsed = parse_episode_dir(name.split("-")[0])
    return parsed[0] if parsed else None


def stream_key(camera: str, kind: str) -> str:
    """'front', 'rgb' -> 'front.rgb' (the prefix of that stream's files)."""
    return f"{camera}.{kind}"


def video_file(camera: str, kind: str) -> str:
    return f"{stream_key(camera, kind)}.{'mkv' if kind == 'depth' else 'mp4'}"


def frames_file(camera: str, kind: str) -> str:
    return f"{stream_key(camera, kind)}.frames.bin"


def escapes(root: Path, entry: Path) -> bool:
    """Whether an entry of the dataset directory resolves outside it (a symlinked episode directory)."""
    return not is_inside(entry, root) or os.path.realpath(entry) == os.path.realpath(root)


def scan(root: Path) -> dict[int, tuple[Path, bool]]:
    """Episode directories under `root`: index -> (path, is_partial). A finished directory wins over
    a partial one of the same index (which a crash between rename steps cannot produce, but a
    user's copy might). One that is a symlink out of the dataset is left out (`escapes`): nothing
    reads it, and repair never writes there."""
    out: dict[int, tuple[Path, bool]] = {}
    if not root.is_dir():
        return out
    for p in sorted(root.iterdir()):
        parsed = parse_episode_dir(p.name) if p.is_dir() else None
        if parsed is None or escapes(root, p):
            continue
        idx, partial = parsed
        if idx in out and not out[idx][1]:
            continue
        out[idx] = (p, partial)
    return out
