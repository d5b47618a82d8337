"""What both nodes of this plugin do the same way around their franky object (a `Robot` or a `Gripper`, or
the fake's): connect through `backend.py` (`FrankaConnection`), turn franky's exceptions into a held fault
or a held, reconnecting link (the core's parts, `rio.interfaces.FaultHolder` and `LinkSupervisor`), and
reconnect once a second after a drop.

A fault does not end the node: libfranka has aborted the motion and the arm holds by itself; the node
reports `fault_code`, refuses commands naming the fault, and `clear_faults()` (or `rio franka recover`
from a shell, or `auto_recover`) runs libfranka's error recovery and enables again holding where the
arm is. A dropped link (franky's `NetworkException`: the Robot object is unusable) is retried once a
second with a new connection; meanwhile `connected` is false and commands are refused.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

from pydantic import Field

from rio import clock
from rio.interfaces import NetworkDevice

from .faults import FrankaSetupError, fault_of_message

log = logging.getLogger("rio_franka")

RETRY_S = 1.0


class FrankaConfig(NetworkDevice):
    """Station fields every node on a Franka control box takes (mixed into each driver's Config)."""

    defaults = {"connect_timeout_s": 0.0}  # one try: a set-up error (versions, FCI) says what to change at once
    backend: str = Field("franky", description='"franky" (the robot), "fake" (a modelled robot, no hardware) or '
                                               '"sim" / "sim:ARM@WORLD" (an arm of a running rio-sim world)')


class FrankaConnection:
    """The franky object of `node` (`handle`, None while the link is down). `connect()` makes a new one;
    `on_connected(handle)` applies what does not survive a new connection (impedances, thresholds)."""

    def __init__(self, node: Any, connect: Callable[[], Any], on_connected: Callable[[Any], None] | None = None):
        self.node, self._connect, self._on_connected = node, connect, on_connected
        self.handle: Any = None
        self._next_try = 0.0

    def open(self, timeout_s: float) -> None:
        """Connect, trying again for up to `timeout_s` while the box does not answer (0: one try)."""
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                self.handle = self._connect()
                break
            except FrankaSetupError:
                if time.monotonic() >= deadline:
                    raise
                time.sleep(0.2)
        if self._on_connected is not None:
            self._on_connected(self.handle)

    def close(self) -> None:
        self.handle = None

    def retry(self) -> None:
        """After a drop, a new connection, tried at most once per `RETRY_S` (the link supervisor's
        `reconnect`). A new connection starts without the fault held before it: the box is asked again."""
        if self.handle is not None or clock.now() < self._next_try:
            return
        self._next_try = clock.now() + RETRY_S
        try:
            handle = self._connect()
            if self._on_connected is not None:
                self._on_connected(handle)
        except FrankaSetupError as e:
            log.debug("node '%s': still no link: %s", self.node.name, e)
            return
        self.handle = handle
        self.node.faults.fault = None

    def drop(self) -> None:
        """franky's object is unusable after a network error: hold the link lost, retry a period later."""
        self.node.link.lost()
        self.handle = None
        self._next_try = clock.now() + RETRY_S

    def call(self, fn: Callable[..., Any], *args: Any) -> Any:
        """Run one device call; franky's errors become the held states (`classify`), returning None."""
        try:
            return fn(*args)
        except Exception as e:
            self.classify(e)
            return None

    def classify(self, e: Exception) -> None:
        """franky's exceptions -> the held, named-fault state or the reconnecting one; others propagate."""
        kind = type(e).__name__
        faults = self.node.faults
        if kind == "NetworkException":
            self.drop()
        elif kind in ("ControlException", "CommandException"):
            faults.report(faults.ask() or fault_of_message(str(e)))
        else:
            raise e
