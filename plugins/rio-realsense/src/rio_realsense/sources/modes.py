"""Stream modes: what a camera offers ("640x480@30 rgb8"), and which depth mode goes with a colour mode.

Colour must match the config exactly (it is what the node publishes). Depth is aligned to colour, so
any depth resolution works; we take the same size when the depth sensor offers it, else the mode at
the same rate with the closest aspect ratio, then the closest width (an L515 with 960x540 colour gets
1024x768 depth).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Mode:
    stream: str  # "color", "depth", "infrared", "accel", ...
    fmt: str  # "rgb8", "z16", ...
    fps: int
    width: int = 0  # 0 for motion streams
    height: int = 0

    def __str__(self) -> str:
        size = f"{self.width}x{self.height}" if self.width else self.stream
        return f"{size}@{self.fps} {self.fmt}"


def _name(enum_value: Any) -> str:
    return str(enum_value).rsplit(".", 1)[-1]


def profile_mode(profile: Any) -> Mode:
    """A `rs.stream_profile` as a Mode."""
    w = h = 0
    if profile.is_video_stream_profile():
        v = profile.as_video_stream_profile()
        w, h = int(v.width()), int(v.height())
    return Mode(_name(profile.stream_type()), _name(profile.format()), int(profile.fps()), w, h)


def sensor_modes(sensor: Any) -> list[Mode]:
    """Every mode a sensor offers, without repeats, in the SDK's order."""
    seen: dict[Mode, None] = {}
    for p in sensor.get_stream_profiles():
        seen.setdefault(profile_mode(p), None)
    return list(seen)


def device_modes(device: Any) -> list[Mode]:
    seen: dict[Mode, None] = {}
    for sensor in device.query_sensors():
        for m in sensor_modes(sensor):
            seen.setdefault(m, None)
    return list(seen)


def pick_depth(modes: Iterable[Mode], width: int, height: int, fps: int,
               want: tuple[int, int] | None = None) -> Mode | None:
    """The z16 depth mode for colour `width`x`height`@`fps` (or exactly `want`), None if there is none."""
    depth = [m for m in modes if m.stream == "depth" and m.fmt == "z16" and m.fps == fps]
    if want is not None:
        return next((m for m in depth if (m.width, m.height) == want), None)
    if not depth:
        return None
    aspect = width / height
    return min(depth, key=lambda m: (abs(m.width / m.height - aspect) > 0.01, abs(m.width - width), m.height))


def offered(modes: Iterable[Mode], stream: str, fmt: str) -> str:
    """'640x480@6/15/30, 1280x720@6/15/30' for messages: the sizes and rates of one stream."""
    by_size: dict[tuple[int, int], list[int]] = {}
    for m in modes:
        if m.stream == stream and m.fmt == fmt:
            by_size.setdefault((m.width, m.height), []).append(m.fps)
    return ", ".join(f"{w}x{h}@{'/'.join(map(str, sorted(set(f))))}" for (w, h), f in sorted(by_size.items())) or "none"
