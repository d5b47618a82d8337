"""What both nodes of this plugin do the same way: connect through `backend.py`, notice a fault or a
dropped link, keep the node alive with the robot held, and recover.

A fault does not end the node: libfranka has aborted the motion and the arm holds by itself; the node
reports `fault_code`, refuses commands naming the fault, and `clear_faults()` (or `rio franka recover`
from a shell, or `auto_recover`) runs libfranka's error recovery and enables again holding where the
arm is. A dropped link (franky's `NetworkException`: the Robot object is unusable) is retried once a
second with a new connection; meanwhile `connected` is false and commands are refused.
"""

from __future__ import annotations

import logging
from typing import Any

from pydantic import Field

from rio import clock
from rio.config import Config
from rio.interfaces import FaultHolding

from .faults import FrankaSetupError, fault_of_message

log = logging.getLogger("rio_franka")

RETRY_S = 1.0


class LinkConfig(Config):
    """Station fields every node on a Franka control box takes (mixed into each driver's Config)."""

    ip: str = Field(description="the robot's FCI address (Desk's IP; the control box's FCI port), e.g. 172.16.0.2")
    backend: str = Field("franky", description='"franky" (the robot), "fake" (a modelled robot, no hardware) or '
                                               '"sim" / "sim:ARM@WORLD" (an arm of a running rio-sim world)')


class FrankaLink(FaultHolding):
    """Mixed in ahead of a commanded kind whose config is a `LinkConfig`; the node defines `connect()`.
    Faults are held the core way (`rio.interfaces.FaultHolding`: `on_fault`, `fault_status()`,
    `clear_faults()`, `fault_info()`); this adds the franky connection, its drops and its exceptions."""

    config: Any
    handle: Any = None  # the franky Robot / Gripper (or the fake's)
    _next_try = 0.0

    def connect(self) -> Any:
        raise NotImplementedError

    def on_connected(self, handle: Any) -> None:
        """Once after every (re)connection: settings that do not survive a new connection."""

    def open_link(self) -> None:
        self.device_label = f"Franka at {self.config.ip}"
        self.handle = self.connect()
        self.on_connected(self.handle)
        self.fault = None

    def close(self) -> None:
        self.handle = None

    # -- connection (a drop is held the core way: on_lost / on_restored) ---------------------------
    def link_up(self) -> bool:
        return self.handle is not None

    def link_status(self) -> dict[str, Any]:
        """Keys every sample carries; also where a dropped link is retried."""
        if self.handle is None and clock.now() >= self._next_try:
            self._next_try = clock.now() + RETRY_S
            try:
                self.open_link()
            except FrankaSetupError as e:
                log.debug("node '%s': still no link: %s", self.name, e)
            else:
                self.on_restored()
        return self.fault_status()

    def on_lost(self) -> None:
        """franky's Robot is unusable after a network error: drop it, retry with a new one."""
        super().on_lost()
        self.handle = None
        self._next_try = clock.now() + RETRY_S

    def classify(self, e: Exception) -> None:
        """franky's exceptions -> the held, named-fault state or the reconnecting one; others propagate."""
        kind = type(e).__name__
        if kind == "NetworkException":
            self.on_lost()
        elif kind in ("ControlException", "CommandException"):
            self.on_fault(self.device_fault() or fault_of_message(str(e)))
        else:
            raise e

    def guarded(self, fn, *args: Any) -> Any:
        """Run one device call; franky's errors become the held states above."""
        try:
            return fn(*args)
        except Exception as e:
            self.classify(e)
            return None
