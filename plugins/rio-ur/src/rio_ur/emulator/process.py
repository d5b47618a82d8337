"""An emulator in a process of its own, steered through its servo port. ur-rtde's blocking calls hold
Python's GIL (its constructors and dashboard replies wait in C++), so an emulator in the driver's own
process would never get to answer: tests, the bench and the station's emulator node all use this. The process
is `rio ur emulator` (`python -m rio ur emulator ...`)."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from typing import Any

from ..loopback import SERVO_PORT, free_loopback


class EmulatorProcess:
    def __init__(self, model: str = "ur5e", host: str | None = None, backend: str = "model", urcap: bool = False):
        self.model, self.host = model, host or free_loopback()
        args = [sys.executable, "-m", "rio", "ur", "emulator", "--model", model, "--ip", self.host,
                "--exit-with", str(os.getpid())]
        args += (["--sim", backend] if backend != "model" else []) + (["--urcap"] if urcap else [])
        self.proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
        self._sock: socket.socket | None = None

    def wait_ready(self, timeout: float = 60.0) -> EmulatorProcess:
        """Block until the emulator answers; if it does not, it is stopped (never left holding its ports)."""
        t_end = time.monotonic() + timeout
        try:
            while time.monotonic() < t_end:
                if self.proc.poll() is not None:
                    raise RuntimeError(f"the UR emulator on {self.host} exited with code {self.proc.returncode}")
                try:
                    self.state()
                    return self
                except OSError:
                    time.sleep(0.1)
            raise TimeoutError(f"the UR emulator on {self.host} did not come up within {timeout:g} s")
        except BaseException:
            self.stop()
            raise

    def _ask(self, line: str) -> str:
        for attempt in (0, 1):
            try:
                if self._sock is None:
                    self._sock = socket.create_connection((self.host, SERVO_PORT), timeout=2.0)
                self._sock.sendall((line + "\n").encode())
                buf = b""
                while not buf.endswith(b"\n"):
                    data = self._sock.recv(65536)
                    if not data:
                        raise ConnectionError("closed")
                    buf += data
                return buf.decode().strip()
            except OSError:
                if self._sock is not None:
                    self._sock.close()
                self._sock = None
                if attempt:
                    raise
        raise AssertionError

    def state(self) -> dict[str, Any]:
        return json.loads(self._ask("state"))

    def inject(self, what: str) -> None:
        self._ask(f"inject {what}")
        if what == "drop":
            self._sock = None

    @property
    def driver_fields(self) -> dict[str, Any]:
        return {"ip": self.host, "control": "emulator", "connect_timeout_s": 5.0}

    def stop(self) -> None:
        if self._sock is not None:
            self._sock.close()
        self.proc.terminate()
        try:
            self.proc.wait(5)
        except subprocess.TimeoutExpired:
            self.proc.kill()

    def __enter__(self) -> EmulatorProcess:
        return self.wait_ready()

    def __exit__(self, *exc: Any) -> None:
        self.stop()
