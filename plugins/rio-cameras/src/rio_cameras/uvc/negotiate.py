"""Ask a webcam for a mode, then read back what the driver actually set, and say how they differ.

V4L2 does not refuse a mode it cannot do: it picks the nearest one it can and reports that. OpenCV's
`set()` returns True either way, so the only truth is `get()` after the request (and the frames). The
order matters to V4L2: the pixel format (FOURCC) first, then the size, then the frame rate. MJPG is
requested by default because uncompressed YUYV at 1280x720 tops out near 10 fps on USB 2.0.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from .._cv import cv2_prop
from ..opencv.capture import fourcc_text


@dataclass(frozen=True)
class Mode:
    width: int
    height: int
    fps: float
    fourcc: str = ""

    def __str__(self) -> str:
        fps = f"{self.fps:g}" if self.fps > 0 else "?"
        return f"{self.width}x{self.height}@{fps}" + (f" {self.fourcc}" if self.fourcc else "")


@dataclass(frozen=True)
class Negotiation:
    requested: Mode
    got: Mode
    #: control name -> (requested, read back)
    controls: dict[str, tuple[float, float]]

    def differences(self) -> list[str]:
        """One phrase per field the driver did not grant ("width 1280 -> 640")."""
        r, g = self.requested, self.got
        out = [f"{name} {a} -> {b}" for name, a, b in (("width", r.width, g.width), ("height", r.height, g.height))
               if a != b]
        if g.fps > 0 and abs(g.fps - r.fps) > 0.5:
            out.append(f"fps {r.fps:g} -> {g.fps:g}")
        if r.fourcc and g.fourcc and g.fourcc != r.fourcc:
            out.append(f"format {r.fourcc} -> {g.fourcc}")
        return out

    def report(self) -> str:
        """'requested 1280x720@30 MJPG, got 640x480@30 YUYV (width 1280 -> 640, ...)'."""
        diff = self.differences()
        text = f"requested {self.requested}, got {self.got}"
        if self.got.fps <= 0:
            text += " (the driver reports no frame rate)"
        return text + (f" ({', '.join(diff)})" if diff else "")


def negotiate(cap: Any, want: Mode, controls: Mapping[str, float] | None = None) -> Negotiation:
    """Request `want` (and the `controls`, e.g. {"autofocus": 0, "focus": 20}) with a 1-frame buffer, then
    read everything back."""
    import cv2

    if want.fourcc:
        cap.set(cv2.CAP_PROP_FOURCC, cv2.VideoWriter.fourcc(*want.fourcc))
    cap.set(cv2.CAP_PROP_FRAME_WIDTH, want.width)
    cap.set(cv2.CAP_PROP_FRAME_HEIGHT, want.height)
    cap.set(cv2.CAP_PROP_FPS, want.fps)
    cap.set(cv2.CAP_PROP_BUFFERSIZE, 1)  # the newest frame, not one queued seconds ago
    controls = dict(controls or {})
    props = {name: cv2_prop(name) for name in controls}
    for name, value in controls.items():
        cap.set(props[name], float(value))
    got = Mode(int(round(cap.get(cv2.CAP_PROP_FRAME_WIDTH))), int(round(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))),
               float(cap.get(cv2.CAP_PROP_FPS)), fourcc_text(cap.get(cv2.CAP_PROP_FOURCC)))
    read_back = {name: (float(v), float(cap.get(props[name]))) for name, v in controls.items()}
    return Negotiation(want, got, read_back)

