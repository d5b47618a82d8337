"""What both gripper drivers do around the link to their gripper (a Modbus RTU client, the Robotiq URCap
socket), held as the node's `device`: open it (starting a private emulator first for an "emulator"
address, held as `_emulator`), bring the gripper up over it (Robotiq activation, DH initialization), and
release both, when the node closes and when bringing the gripper up fails."""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from .emulator import private
from .errors import CommunicationError
from .models import GripperModel

log = logging.getLogger("rio_robotiq")


def model_width(max_width: float | None, spec: GripperModel) -> float:
    """The configured full opening, or the model's stroke when none is; wider than the stroke is an error."""
    if max_width is None:
        return spec.stroke
    if max_width > spec.stroke + 1e-9:
        raise ValueError(f"max_width {max_width} m is wider than the {spec.label} opens ({spec.stroke} m)")
    return max_width


def open_device(node: Any, connect: Callable[[], Any], bring_up: Callable[[], None]) -> None:
    """`node.device = connect()` (which may start `node._emulator`), then `bring_up()`; a failure on the way
    releases both before it goes on."""
    try:
        node.device = connect()
        bring_up()
    except BaseException:
        close_device(node)
        raise


def close_device(node: Any) -> None:
    """Close `node.device` and stop `node._emulator` (each at most once)."""
    try:
        if node.device is not None:
            node.device.close()
    except CommunicationError as e:
        log.warning("%s: closing the link: %s", node.spec.label, e)
    finally:
        node.device = None
        private.stop(node._emulator)
        node._emulator = None
