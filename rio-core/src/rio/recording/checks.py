"""What is checked of an episode besides its files' sha256: that the values its episode.json holds are
possible, and that they agree with its files.

Why: the sha256 in episode.json proves a file unchanged since episode.json was written, not that
episode.json itself makes sense. A downloaded dataset can carry valid JSON with impossible values (fps 0
or NaN, a length of 10^12, a stream of an unknown kind, a "video" that is a text file, the hashes
written to match): readers and exporters would then allocate 10^12 rows or hand garbage to a video
decoder and end in a traceback. Both checks return problems in words, one per field, so `rio datasets
info` lists them as damage and export, replay and merge refuse the episode in one line:

- `metadata_problems(meta)`: the values alone (types and ranges); run whenever episode.json is loaded, so
  such a file counts as damaged metadata (`rio datasets repair` rebuilds it from the data files);
- `file_problems(ep)`: the values against the files: steps.bin holds `length` records, each stream has
  its frame column in steps.json and its `*.frames.bin` holds `frames` records, every stream's files stay
  inside the episode and are listed (with their sha256) in `files`, and each video opens as a video of
  the recorded size.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from rio.machine.confine import inside
from rio.recording import paths as L
from rio.recording.episode_writer import FRAME_RECORD
from rio.recording.flatten import CAMERA_KINDS

if TYPE_CHECKING:
    from rio.recording.dataset import Episode


def _count(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and v >= 0


def _positive(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0


def metadata_problems(meta: dict[str, Any]) -> list[str]:
    """Impossible values of an episode.json (already parsed to a dict), one line per field."""
    out: list[str] = []
    if not _count(meta.get("index")):
        out.append(f"index: {meta.get('index')!r} is not an episode number (a whole number >= 0)")
    if not _count(meta.get("length")):
        out.append(f"length: {meta.get('length')!r} is not a number of steps (a whole number >= 0)")
    if not _positive(meta.get("fps")):
        out.append(f"fps: {meta.get('fps')!r} is not a rate (a finite number > 0)")
    files = meta.get("files", {})
    if not isinstance(files, dict):
        out.append(f"files: a {type(files).__name__}, not a table of files")
    else:
        for name, want in files.items():
            if not isinstance(want, dict) or not _count(want.get("bytes")) or not isinstance(want.get("sha256"), str):
                out.append(f"files[{name!r}]: not {{bytes, sha256}}")
    streams = meta.get("streams", {})
    if not isinstance(streams, dict):
        return [*out, f"streams: a {type(streams).__name__}, not a table of camera streams"]
    for key, s in streams.items():
        where = f"streams[{key!r}]"
        if not isinstance(s, dict):
            out.append(f"{where}: not a camera stream's description")
            continue
        camera, kind = s.get("camera"), s.get("kind")
        if kind not in CAMERA_KINDS:
            out.append(f"{where}.kind: {kind!r} is not a stream kind ({', '.join(CAMERA_KINDS)})")
        if not isinstance(camera, str) or not camera or L.stream_key(camera, str(kind)) != key:
            out.append(f"{where}.camera: {camera!r} does not name this stream")
        for f in ("file", "frames_file"):
            if not isinstance(s.get(f), str) or not s.get(f):
                out.append(f"{where}.{f}: {s.get(f)!r} is not a file name")
        if not _count(s.get("frames")):
            out.append(f"{where}.frames: {s.get('frames')!r} is not a number of frames")
        for f in ("height", "width"):
            if not _count(s.get(f)) or s.get(f) == 0:
                out.append(f"{where}.{f}: {s.get(f)!r} is not an image size (a whole number > 0)")
        if s.get("rate") is not None and not _positive(s.get("rate")):
            out.append(f"{where}.rate: {s.get('rate')!r} is not a frame rate (a finite number > 0)")
        if "depth_unit_m" in s and not _positive(s.get("depth_unit_m")):
            out.append(f"{where}.depth_unit_m: {s.get('depth_unit_m')!r} is not a length (a finite number > 0)")
    return out


def file_problems(ep: Episode, video: bool = True) -> list[str]:
    """Where a (metadata-valid) episode.json disagrees with the episode's files; `video`: also open every
    video to see that it is one, of the recorded size (PyAV; skipped without it)."""
    out: list[str] = []
    meta_path = ep.path / L.EPISODE_META
    steps = ep.path / L.STEPS
    if ep.schema.dtype.itemsize == 0:
        out.append(f"{L.STEPS_SCHEMA}: a step layout without fields")
    elif steps.is_file():
        have = steps.stat().st_size // ep.schema.dtype.itemsize
        if have != ep.length:
            out.append(f"length: {ep.length} steps, but {L.STEPS} holds {have}")
    listed = ep.meta.get("files", {})
    for key, s in ep.streams.items():
        where = f"streams[{key!r}]"
        if f"cam.{key}" not in ep.schema.names:
            out.append(f"{where}: {L.STEPS_SCHEMA} has no column cam.{key} (no step says which frame it saw)")
            continue
        try:
            vfile = inside(ep.path, s["file"], source=meta_path, field=f"{where}.file")
            ffile = inside(ep.path, s["frames_file"], source=meta_path, field=f"{where}.frames_file")
        except Exception as e:  # noqa: BLE001 - OutsideRoot: reported as a problem, never followed
            out.append(str(e))
            continue
        if s["frames"] > 0:
            unlisted = [n for n in (s["file"], s["frames_file"]) if n not in listed]
            if unlisted:
                out.append(f"{where}: {', '.join(unlisted)} not listed in files (its sha256 was never recorded)")
                continue
        if ffile.is_file() and ffile.stat().st_size != s["frames"] * FRAME_RECORD.itemsize:
            out.append(f"{where}.frames: {s['frames']} frames, but {s['frames_file']} holds "
                       f"{ffile.stat().st_size // FRAME_RECORD.itemsize}")
        if video and s["frames"] > 0 and vfile.is_file():
            bad = _video_problem(vfile, s["height"], s["width"])
            if bad:
                out.append(f"{where}.file: {s['file']} {bad}")
    return out


def _video_problem(path: Any, height: int, width: int) -> str | None:
    """Why `path` is not a video of height x width (a coded size padded by one pixel is fine: 4:2:0)."""
    try:
        import av
    except ImportError:
        return None
    try:
        with av.open(str(path)) as container:
            if not container.streams.video:
                return "holds no video stream"
            cc = container.streams.video[0].codec_context
            h, w = cc.height, cc.width
    except Exception as e:  # noqa: BLE001 - av.error.*: whatever FFmpeg says, the file is no video
        return f"is not a video ({type(e).__name__})"
    if not (height <= h <= height + 1 and width <= w <= width + 1):
        return f"is {w}x{h}, the stream says {width}x{height}"
    return None
