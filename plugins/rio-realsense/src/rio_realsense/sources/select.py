"""Which connected camera a driver opens: by serial number, or the only one of its product line.

Kept apart from the pipeline so the rules can be checked without cameras: `select_device` only calls
`get_info` / `supports` on what `rs.context().query_devices()` returns (tests pass stand-ins of those
devices: the SDK's software devices cannot be added to a context in pyrealsense2 2.59).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from ..errors import RealSenseError

#: Config `product_line` -> what `rs.camera_info.product_line` reports, and the driver for it.
PRODUCT_LINES = {"d400": "D400", "l500": "L500"}
DRIVERS = {"D400": "realsense.d400", "L500": "realsense.l515"}


@dataclass(frozen=True)
class Found:
    """A connected camera as the SDK describes it."""

    serial: str
    name: str
    product_line: str
    device: Any

    def __str__(self) -> str:
        return f"{self.serial} ({self.name})"


def describe(devices: Iterable[Any]) -> list[Found]:
    """Serial, name and product line of each device (a device that cannot say is named '?')."""
    import pyrealsense2 as rs

    def info(dev: Any, what: Any) -> str:
        try:
            return str(dev.get_info(what)) if dev.supports(what) else "?"
        except RuntimeError:  # unplugged while being listed
            return "?"

    return [Found(info(d, rs.camera_info.serial_number), info(d, rs.camera_info.name),
                  info(d, rs.camera_info.product_line), d) for d in devices]


def select_device(devices: Iterable[Any], serial: str, product_line: str) -> Found:
    """The device to open. `serial` picks one exactly; empty picks the only camera of `product_line`
    ('d400' or 'l500'). Raises `RealSenseError` naming every connected serial when that is ambiguous
    or impossible, so the user can copy the right one into the station file."""
    found = describe(devices)
    line = PRODUCT_LINES[product_line]
    listing = ", ".join(map(str, found)) or "none"
    if serial:
        match = [f for f in found if f.serial == serial]
        if not match:
            raise RealSenseError(serial, f"not connected (connected: {listing}); check the cable, "
                                 "or find serials with `rio cameras list`")
        dev = match[0]
        if dev.product_line not in ("?", line):
            other = DRIVERS.get(dev.product_line, "a driver for that camera")
            raise RealSenseError(serial, f"is a {dev.name} ({dev.product_line} product line), not a {line} camera: "
                                 f"use driver = \"{other}\"")
        return dev
    mine = [f for f in found if f.product_line in (line, "?")]
    if len(mine) == 1:
        return mine[0]
    if not mine:
        raise RealSenseError("", f"no {line} camera connected (connected: {listing}); plug one in, or set "
                             "source = \"software\" to try the driver without a camera")
    raise RealSenseError("", f"{len(mine)} {line} cameras connected ({', '.join(map(str, mine))}): "
                         "set `serial` to the one this component is")
