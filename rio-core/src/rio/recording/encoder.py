"""The recorder's handle on its encoder process (see `encoder_main`): start it, map frame rings,
push frames (never blocking), and close or abort an episode's streams."""

from __future__ import annotations

import itertools
import os
import socket
import subprocess
import sys
import time
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

import numpy as np

from rio.errors import RioError
from rio.recording.frame_ring import FrameRing
from rio.recording.video import VideoOptions


class EncoderError(RioError):
    """The encoder process failed or went away."""


class EncoderProcess:
    def __init__(self, nice: int = 10):
        # A fresh interpreter (`python -m`), not fork (the caller may own middleware threads) and not
        # multiprocessing's spawn (which re-imports the caller's __main__, breaking plain scripts).
        ours, theirs = socket.socketpair()
        # Blocking, whatever `socket.setdefaulttimeout()` this process was given (the xArm SDK sets 1 s for the
        # whole process when it connects): a socket made under a default timeout is non-blocking, the encoder
        # inherits its end so, and its first read with nothing pending fails with EAGAIN, which it took for
        # the recorder's exit (multiprocessing.Pipe sets its ends blocking for the same reason).
        ours.setblocking(True)
        theirs.setblocking(True)
        self.proc = subprocess.Popen([sys.executable, "-m", "rio.recording.encoder_main", str(theirs.fileno()),
                                      str(nice)], pass_fds=(theirs.fileno(),), stdin=subprocess.DEVNULL)
        theirs.close()
        # Commands go through `conn`, frame-ring descriptors through `_sock`: two descriptors of our end, each
        # closed once by its owner. Not multiprocessing's send_handle: it wraps the command descriptor in a new
        # socket object per call, which a default timeout makes non-blocking, and the flag is our end's, shared.
        self._sock = ours
        self.conn = Connection(os.dup(ours.fileno()))
        self.rings: dict[str, FrameRing] = {}
        self.errors: dict[str, str] = {}
        self._tokens = itertools.count()

    # -- streams ------------------------------------------------------------------------------------
    def ensure_ring(self, key: str, shape: tuple[int, ...], dtype: np.dtype, slots: int) -> FrameRing:
        from multiprocessing.reduction import sendfds

        ring = self.rings.get(key)
        if ring is not None and ring.shape == tuple(shape) and ring.dtype == np.dtype(dtype):
            return ring
        if ring is not None:
            self.wait_idle(key)
        ring = FrameRing(shape, np.dtype(dtype).str, slots)
        self._send(("ring", key, tuple(shape), np.dtype(dtype).str, slots))
        sendfds(self._sock, [ring.fd])  # what the encoder's recv_handle reads
        old = self.rings.pop(key, None)
        if old is not None:
            old.close()
        self.rings[key] = ring
        return ring

    def open(self, key: str, path: Path, kind: str, height: int, width: int, rate: float,
             options: VideoOptions) -> None:
        self.errors.pop(key, None)
        self._send(("open", key, str(path), kind, int(height), int(width), float(rate), options.to_json()))

    def reserve(self, key: str) -> tuple[int, np.ndarray] | None:
        """A free slot of the stream's ring and its array, to fill in place and then `commit`; None if the
        ring is full (the frame is dropped)."""
        self.poll()  # slots the encoder released since
        ring = self.rings[key]
        slot = ring.reserve()
        return None if slot is None else (slot, ring.view(slot))

    def commit(self, key: str) -> None:
        """The slot `reserve` gave is filled (not yet sent: `encode` it, now or once its stream is open)."""
        self.rings[key].commit()

    def encode(self, key: str, slot: int, depth_scale: float | None = None) -> None:
        """Encode a committed slot. `depth_scale`: the slot holds depth in units of that many meters (as
        the camera published it), not meters."""
        self._send(("frame", key, int(slot), depth_scale))

    def close_streams(self, keys: list[str], timeout: float = 60.0) -> dict[str, dict]:
        token = next(self._tokens)
        self._send(("close", token, list(keys)))
        reply = self._wait(("closed", token), timeout)
        return reply[2]

    def abort_streams(self, keys: list[str], timeout: float = 10.0) -> None:
        token = next(self._tokens)
        self._send(("abort", token, list(keys)))
        self._wait(("aborted", token), timeout)

    def wait_idle(self, key: str, timeout: float = 10.0) -> None:
        ring = self.rings[key]
        t_end = time.monotonic() + timeout
        while ring.backlog() and time.monotonic() < t_end:
            self.poll()
            time.sleep(0.002)

    def backlog(self) -> int:
        return max((r.backlog() for r in self.rings.values()), default=0)

    # -- plumbing -----------------------------------------------------------------------------------
    def alive(self) -> bool:
        return self.proc.poll() is None

    def exit_reason(self) -> str:
        """How the process ended, for error messages: a signal (killed: memory? someone's kill?) or an exit
        code (0: it saw its command pipe close, i.e. this process lost its end of it)."""
        code = self.proc.poll()
        if code is None:
            return "still running"
        if code < 0:
            import signal

            try:
                name = signal.Signals(-code).name
            except ValueError:
                name = f"signal {-code}"
            return f"killed by {name}"
        return "exit code 0: its command pipe closed under it" if code == 0 else f"exit code {code}"

    def poll(self) -> None:
        """Collect asynchronous error reports (never blocks)."""
        try:
            while self.conn.poll():
                self._handle(self.conn.recv())
        except (EOFError, OSError):
            pass

    def _handle(self, msg: Any) -> None:
        if msg[0] == "released":
            if (ring := self.rings.get(msg[1])) is not None:
                ring.released()
        elif msg[0] == "error":
            self.errors[msg[1]] = msg[2]

    def _send(self, msg: Any) -> None:
        if not self.alive():
            raise EncoderError(f"the encoder process exited (code {self.proc.returncode})")
        self.conn.send(msg)

    def _wait(self, head: tuple, timeout: float) -> Any:
        t_end = time.monotonic() + timeout
        while time.monotonic() < t_end:
            if self.conn.poll(0.05):
                try:
                    msg = self.conn.recv()
                except (EOFError, OSError):
                    break
                if tuple(msg[:2]) == head:
                    return msg
                self._handle(msg)
            elif not self.alive():
                break
        raise EncoderError(f"the encoder process did not answer {head[0]!r} within {timeout:g} s "
                           f"(exit code: {self.proc.poll()})")

    def shutdown(self, timeout: float = 30.0) -> None:
        try:
            if self.alive():
                self.conn.send(("exit",))
                self.proc.wait(timeout)
        except (OSError, subprocess.TimeoutExpired):
            pass
        if self.alive():
            self.proc.terminate()
            try:
                self.proc.wait(2.0)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.conn.close()
        self._sock.close()
        for r in self.rings.values():
            r.close()
        self.rings.clear()
