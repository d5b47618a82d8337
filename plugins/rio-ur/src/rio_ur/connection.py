"""`URConnection`, one arm's connections: the RTDE receive stream (state), the control interface (servo targets, see
`control.py`) and the Dashboard Server (power, brakes, protective stop), opened and re-opened here.

ur-rtde's receive interface runs its own thread filling the latest state at 500 Hz, so reading a sample
is a copy, never a round trip. A dropped link shows as `isConnected()` false; `reconnect()` retries
once a second and re-opens the control interface, and the driver holds where the arm is afterwards.
"""

from __future__ import annotations

import logging
import time
from typing import Any

import numpy as np

from .control import open_control
from .faults import REMOTE_HINT, URError

log = logging.getLogger("rio_ur")

#: The RTDE outputs the driver reads (a fixed recipe: fewer bytes at 500 Hz than ur-rtde's default).
OUTPUTS = ["timestamp", "actual_q", "actual_qd", "actual_TCP_pose", "target_q", "robot_mode", "safety_mode",
           "safety_status_bits", "runtime_state", "speed_scaling"]


class URConnection:
    def __init__(self, ip: str, control: str, rate_hz: float, connect_timeout_s: float):
        self.ip, self.kind, self.rate_hz, self.connect_timeout_s = ip, control, rate_hz, connect_timeout_s
        self.recv: Any = None
        self.ctl: Any = None
        self._last_try = -np.inf

    def open(self) -> None:
        from rtde_receive import RTDEReceiveInterface

        deadline = time.monotonic() + self.connect_timeout_s
        while True:
            try:
                self.recv = RTDEReceiveInterface(self.ip, 500.0, OUTPUTS)
                break
            except RuntimeError as e:
                if time.monotonic() > deadline:
                    raise URError(self.ip, "connect", f"no RTDE answer on TCP 30004 within "
                                  f"{self.connect_timeout_s:g} s ({e}); check the IP and cable (`ping {self.ip}`), "
                                  "or run `rio ur emulator`") from None
                time.sleep(0.2)
        self.ctl = open_control(self.kind, self.ip, self.rate_hz)

    def close(self) -> None:
        if self.ctl is not None:
            try:
                self.ctl.servoStop()
                self.ctl.stopScript()
            except Exception:  # closing goes on: the arm stops by itself when the script ends
                pass
            self.ctl.disconnect()
            self.ctl = None
        if self.recv is not None:
            self.recv.disconnect()
            self.recv = None

    @property
    def connected(self) -> bool:
        return self.recv is not None and bool(self.recv.isConnected()) and self.ctl is not None

    def reconnect(self, period_s: float = 1.0) -> bool:
        if self.connected:
            return True
        now = time.monotonic()
        if self._last_try == -np.inf:  # just noticed: the first try comes a period later, like the next ones
            self._last_try = now
        if now - self._last_try < period_s:
            return False
        self._last_try = now
        try:
            if self.recv is not None and not self.recv.isConnected():
                self.recv.reconnect()
            if self.ctl is not None:
                self.ctl.disconnect()
            self.ctl = open_control(self.kind, self.ip, self.rate_hz)
        except Exception as e:
            self.ctl = None
            log.warning("UR at %s: reconnect failed: %s", self.ip, e)
            return False
        log.warning("UR at %s: reconnected", self.ip)
        self._last_try = -np.inf
        return True

    def dashboard(self) -> Any:
        """A fresh Dashboard Server connection (port 29999) for one request."""
        from dashboard_client import DashboardClient

        d = DashboardClient(self.ip)
        try:
            d.connect()
        except RuntimeError as e:
            raise URError(self.ip, "dashboard", f"no Dashboard Server on TCP 29999 ({e})") from None
        return d

    def check_remote(self) -> None:
        d = self.dashboard()
        try:
            if not d.isInRemoteControl():
                raise URError(self.ip, "control", REMOTE_HINT)
        finally:
            d.disconnect()
