"""Video streams with PyAV: the encoder settings, one writer per camera stream, and the reader.

RGB is H.264 (libx264) or AV1 (libsvtav1) in fragmented MP4: every finished fragment (one GOP) is
decodable even if the writer is killed, which is what makes an interrupted episode recoverable.
Depth is stored losslessly as 16-bit integers (default unit 1 mm) with FFV1 in Matroska.
Frames get consecutive pts at the stream's nominal rate; the true capture time of every frame is
kept beside the video (`*.frames.bin`), so players show the stream at the right speed and no
timing information depends on the container.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from dataclasses import asdict, dataclass
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from rio.schema import depth_meters

if TYPE_CHECKING:
    from av.video.stream import VideoStream

CODECS = {"h264": "libx264", "av1": "libsvtav1", "hevc": "libx265"}


@dataclass
class VideoOptions:
    """How camera streams are encoded while recording.

    The defaults (H.264, CRF 28, `veryfast`, a keyframe every 2 s) keep three 640x480 cameras at
    30 fps in real time on two cores at under 10 MB per minute (see bench/recording.py).
    """

    codec: str = "h264"  # h264 | av1 | hevc
    crf: int = 28
    preset: str = "veryfast"  # x264/x265 preset name; for av1 an SVT-AV1 preset number (e.g. "10")
    gop_s: float = 2.0  # keyframe interval in seconds: bounds what a crash can lose from a stream
    threads: int = 2  # encoder threads per stream
    depth_unit_m: float = 0.001  # depth is stored as uint16 multiples of this (1 mm: up to 65.5 m)

    def to_json(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_any(cls, value: VideoOptions | dict | str | None) -> VideoOptions:
        if value is None:
            return cls()
        if isinstance(value, VideoOptions):
            return value
        if isinstance(value, str):
            return cls(codec=value)
        return cls(**value)

    def encoder_options(self, rate: float) -> tuple[str, dict[str, str]]:
        if self.codec not in CODECS:
            raise ValueError(f"unknown video codec '{self.codec}'; choose one of {sorted(CODECS)}")
        name = CODECS[self.codec]
        g = str(max(1, round(self.gop_s * rate)))
        if self.codec == "av1":
            quiet_svt()
            preset = self.preset if self.preset.isdigit() else "10"
            return name, {"crf": str(self.crf), "preset": preset, "g": g,
                          "svtav1-params": f"lp={self.threads}:rc=0"}
        return name, {"crf": str(self.crf), "preset": self.preset, "g": g, "threads": str(self.threads)}


def quiet_svt() -> None:
    """SVT-AV1 prints its settings and advice to stderr on every encoder it opens (two dozen `Svt[info]` and
    `Svt[warn]` lines an export): errors only, unless the user set `SVT_LOG` (3 shows everything). Read by the
    library when it first logs, so call it before opening an AV1 stream."""
    os.environ.setdefault("SVT_LOG", "1")


def video_problem(options: VideoOptions, depth: bool = True) -> str | None:
    """Why camera streams could not be encoded here (PyAV missing, or its FFmpeg lacking the encoder), or
    None. Asked before the first episode: finding out in the encoder process would keep episodes
    without their video."""
    try:
        import av
    except ImportError:
        return "recording cameras needs PyAV: pip install 'rio-core[record]' (or pip install av)"
    wanted = [CODECS[options.codec]] + (["ffv1"] if depth else [])
    for name in wanted:
        try:
            av.codec.Codec(name, "w")
        except Exception:  # av.codec.codec.UnknownCodecError, or no encoder of that name in this FFmpeg
            return (f"this PyAV's FFmpeg has no '{name}' encoder (codec '{options.codec}'): install the PyAV wheel "
                    "from PyPI (pip install --force-reinstall av) or choose another codec")
    return None


def depth_units(meters: np.ndarray, unit_m: float) -> np.ndarray:
    """Depth in meters as the stored uint16 multiples of `unit_m` (no reading, NaN or inf: 0). When a
    camera's own unit is `unit_m`, this gives back exactly its integers (float32 round trip, rounded)."""
    d = np.nan_to_num(meters / unit_m, nan=0.0, posinf=0.0, neginf=0.0)
    return np.clip(np.rint(d), 0, 65535).astype(np.uint16)


def _rate(rate: float) -> Fraction:
    return Fraction(rate).limit_denominator(1001)


@contextlib.contextmanager
def scheduling_kept() -> Iterator[None]:
    """The calling thread's scheduling policy as it was before the block: SVT-AV1 (libsvtav1), run as root,
    puts the thread that opens and feeds its encoder at SCHED_FIFO 99 and leaves it there, so every thread that
    thread starts afterwards is real-time too (in a test process: a later test's busy-waiting thread at FIFO 99
    starved the machine). The encoder's own threads stay at SVT-AV1's FIFO 99 while it is open."""
    try:
        old = (os.sched_getscheduler(0), os.sched_getparam(0))
    except (AttributeError, OSError):  # no POSIX scheduling here
        yield
        return
    try:
        yield
    finally:
        if (os.sched_getscheduler(0), os.sched_getparam(0)) != old:
            with contextlib.suppress(OSError):
                os.sched_setscheduler(0, old[0], old[1])


class StreamWriter:
    """Encodes one camera stream into one file (runs in the encoder process)."""

    def __init__(self, path: str | Path, kind: str, height: int, width: int, rate: float, options: VideoOptions):
        import av

        self.path, self.kind, self.options = Path(path), kind, options
        self.height, self.width = height, width
        self.frames = 0
        if kind == "depth":
            # flush_packets: every packet reaches the file at once, not when a 32 KB buffer fills,
            # so a killed encoder loses at most its current fragment/packet
            # Matroska holds a whole cluster in memory: close one every gop_s so a crash loses little
            self.container = av.open(str(self.path), "w", format="matroska", options={
                "flush_packets": "1", "cluster_time_limit": str(max(int(options.gop_s * 1000), 100)),
                "cluster_size_limit": str(4 << 20)})
            self.stream = self.container.add_stream("ffv1", rate=_rate(rate), options={"level": "3", "slices": "4",
                                                                                       "slicecrc": "1"})
            self.stream.pix_fmt = "gray16le"
            self.enc_h, self.enc_w = height, width
        else:
            codec, opts = options.encoder_options(rate)
            self.container = av.open(str(self.path), "w", format="mp4",
                                     options={"movflags": "frag_keyframe+empty_moov+default_base_moof",
                                              "flush_packets": "1"})
            # a codec name from CODECS, all video encoders (av types a name it cannot check as any stream)
            self.stream = cast("VideoStream", self.container.add_stream(codec, rate=_rate(rate), options=opts))
            self.stream.pix_fmt = "yuv420p"
            # 4:2:0 needs even sizes: pad by one pixel (the reader crops back to height x width)
            self.enc_h, self.enc_w = height + height % 2, width + width % 2
        self.stream.height, self.stream.width = self.enc_h, self.enc_w

    def _prepare(self, frame: np.ndarray, depth_scale: float | None = None) -> np.ndarray:
        if self.kind == "depth":
            if depth_scale is not None:  # the camera's own units: stored as they are when they are ours
                if np.float32(depth_scale) == np.float32(self.options.depth_unit_m):
                    return np.ascontiguousarray(frame, dtype=np.uint16)
                frame = depth_meters(frame, depth_scale)
            if frame.dtype.kind == "f":
                return depth_units(frame, self.options.depth_unit_m)
            return np.ascontiguousarray(frame, dtype=np.uint16)
        if (self.enc_h, self.enc_w) != frame.shape[:2]:
            frame = np.pad(frame, ((0, self.enc_h - frame.shape[0]), (0, self.enc_w - frame.shape[1]), (0, 0)),
                           mode="edge")
        return np.ascontiguousarray(frame, dtype=np.uint8)

    def write(self, frame: np.ndarray, depth_scale: float | None = None) -> None:
        """Encode one frame: rgb (H, W, 3) uint8; depth in meters, or in units of `depth_scale` meters."""
        import av

        fmt = "gray16le" if self.kind == "depth" else "rgb24"
        vf = av.VideoFrame.from_ndarray(self._prepare(frame, depth_scale), format=fmt)
        vf.pts = self.frames
        self.frames += 1
        with scheduling_kept():  # the first frame opens the encoder
            packets = self.stream.encode(vf)
        for packet in packets:
            self.container.mux(packet)

    def close(self) -> int:
        with scheduling_kept():
            packets = self.stream.encode()
        for packet in packets:
            self.container.mux(packet)
        self.container.close()
        return self.frames


def read_frames(path: str | Path, kind: str, height: int | None = None, width: int | None = None,
                tolerate_truncation: bool = False):
    """Decoded frames in order: HxWx3 uint8 (rgb) or HxW uint16 (depth, in the stream's units).

    With `tolerate_truncation`, stops quietly at the first undecodable packet (a crashed
    recording's torn last fragment) instead of raising."""
    import av

    fmt = "gray16le" if kind == "depth" else "rgb24"
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        try:
            for packet in container.demux(stream):
                for frame in packet.decode():
                    arr = frame.to_ndarray(format=fmt)
                    if height is not None and width is not None:
                        arr = arr[:height, :width]
                    yield arr
        except av.error.FFmpegError:
            if not tolerate_truncation:
                raise
