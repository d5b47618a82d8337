"""A serial device on a pseudo-terminal: the driver opens `port` (the pty's slave path) through its
usual serial library and sees the bytes a USB-RS485 adapter would give it.

Subclasses write `on_data(data) -> bytes`: bytes that arrived (any split: serial has no packets), the
reply to write back. One thread (named `thread_name` and the port) serves the master side; the device
keeps the slave open itself, so a driver may close and reopen the port while the device lives.
`start=False` opens the pty without serving it yet: set the device up, then `start()`.
"""

from __future__ import annotations

import logging
import os
import select
import threading
import tty
from collections.abc import Callable
from typing import Any, TypeVar

from rio.machine.servo_port import mark_emulated

log = logging.getLogger("rio.emulation")

_D = TypeVar("_D", bound="PtyDevice")


class PtyDevice:
    #: Prefix of the serving thread's name.
    thread_name = "rio-pty"

    def __init__(self, *, start: bool = True):
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no echo, no line editing: bytes pass as they are
        self.port = os.ttyname(self._slave)
        mark_emulated(self.port)  # drivers opening it allow for a thread that answers late (rio.machine.servo_port)
        #: Taken while input is handled; hold it to change the device consistently from another thread.
        self.lock = threading.RLock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._on_close: list[Callable[[], object]] = []
        if start:
            self.start()

    def on_data(self, data: bytes) -> bytes:
        raise NotImplementedError

    def start(self: _D) -> _D:
        if self._thread is None:
            self._thread = threading.Thread(target=self._serve, name=f"{self.thread_name}-{self.port}", daemon=True)
            self._thread.start()
        return self

    def close(self) -> None:
        mark_emulated(self.port, False)
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2.0)
            self._thread = None
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass
        self._master = self._slave = -1
        while self._on_close:
            self._on_close.pop()()

    def on_close(self, fn: Callable[[], object]) -> None:
        """Call `fn()` when the device closes (release what it is attached to)."""
        self._on_close.append(fn)

    def __enter__(self: _D) -> _D:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def _serve(self) -> None:
        while not self._stop.is_set():
            try:
                ready, _, _ = select.select([self._master], [], [], 0.05)
                if not ready:
                    continue
                data = os.read(self._master, 4096)
            except OSError:  # closed under us
                return
            try:
                with self.lock:
                    reply = self.on_data(data)
            except Exception:  # an emulator bug must look like a silent device, not kill the port
                log.exception("emulated device on %s: cannot handle %s", self.port, data.hex(" "))
                continue
            if reply:
                try:
                    os.write(self._master, reply)
                except OSError:
                    return
