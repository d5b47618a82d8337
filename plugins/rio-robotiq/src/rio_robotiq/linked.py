"""`LinkedGripper`: the lifecycle both gripper drivers share. A driver opens a link to its gripper (a
Modbus RTU client, the Robotiq URCap socket) in `connect()`, starting a private emulator first for a
"virtual" address (`self._virtual`), then brings the gripper up (Robotiq activation, DH
initialization) in `bring_up()`. A failure on the way, and `close()`, release both: the link is closed
and the emulator stopped."""

from __future__ import annotations

import logging
from typing import Any

from rio.interfaces import GripperNode

from . import virtual
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


class LinkedGripper(GripperNode):
    spec: GripperModel

    def setup(self) -> None:
        super().setup()
        #: the open link (`close()`, `where`); None while closed
        self.link: Any = None
        self._virtual: Any = None

    # -- what a driver writes ---------------------------------------------------------------------------
    def connect(self) -> Any:
        """Open and return the link (for a virtual address, start `self._virtual` and link to it)."""
        raise NotImplementedError

    def bring_up(self) -> None:
        """Make the gripper ready to move over `self.link` (activate, initialize)."""
        raise NotImplementedError

    # -- lifecycle --------------------------------------------------------------------------------------
    def open(self) -> None:
        try:
            self.link = self.connect()
            self.bring_up()
        except BaseException:
            self._release()
            raise

    def close(self) -> None:
        self._release()

    def _release(self) -> None:
        try:
            if self.link is not None:
                self.link.close()
        except CommunicationError as e:
            log.warning("%s: closing the link: %s", self.spec.label, e)
        finally:
            self.link = None
            virtual.stop(self._virtual)
            self._virtual = None
