"""The seam between the driver and the controller's control path.

On a real arm, ur-rtde's `RTDEControlInterface` uploads a URScript (port 30003) and streams targets
through RTDE input registers: `servoJ`, `servoL`, `servoStop`, `setTcp`. That script cannot reasonably
be emulated (it would mean interpreting URScript), so against the emulator the driver takes an
`EmulatedControl` with the same methods, which sends each call to the emulator's servo port
(`emulator/servo.py`). Everything else (state, dashboard) is the real ur-rtde against the emulated
protocols.
"""

from __future__ import annotations

import socket
from collections.abc import Sequence
from typing import Any

from .faults import REMOTE_HINT, URError
from .loopback import SERVO_PORT


class EmulatedControl:
    """`RTDEControlInterface`'s servo subset over the emulator's servo port."""

    def __init__(self, ip: str, timeout_s: float = 5.0):
        self.ip = ip
        self.sock = socket.create_connection((ip, SERVO_PORT), timeout=timeout_s)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._buf = b""
        self._ask("control")

    def _ask(self, line: str) -> str:
        try:
            self.sock.sendall((line + "\n").encode())
            while b"\n" not in self._buf:
                data = self.sock.recv(4096)
                if not data:
                    raise ConnectionError("the emulator closed the servo port")
                self._buf += data
        except OSError:
            self.sock.close()
            raise
        reply, self._buf = self._buf.split(b"\n", 1)
        return reply.decode()

    @staticmethod
    def _nums(v: Sequence[float]) -> str:
        return " ".join(repr(float(x)) for x in v)

    def servoJ(self, q, speed, accel, dt, lookahead_time, gain) -> bool:  # noqa: N802 (ur-rtde's names)
        return self._ask(f"servoj {float(lookahead_time)!r} {self._nums(q)}") == "ok"

    def servoL(self, pose, speed, accel, dt, lookahead_time, gain) -> bool:  # noqa: N802
        return self._ask(f"servol {float(lookahead_time)!r} {self._nums(pose)}") == "ok"

    def servoStop(self, a: float = 10.0) -> bool:  # noqa: N802
        return self._ask("stop") == "ok"

    def setTcp(self, offset) -> bool:  # noqa: N802
        return self._ask(f"tcp {self._nums(offset)}") == "ok"

    def reuploadScript(self) -> bool:  # noqa: N802
        return True

    def isConnected(self) -> bool:  # noqa: N802
        return self.sock.fileno() >= 0

    def stopScript(self) -> None:  # noqa: N802
        pass

    def disconnect(self) -> None:
        self.sock.close()


def open_control(kind: str, ip: str, rate_hz: float) -> Any:
    """The control interface the driver streams through: "rtde" (ur-rtde, the real arm) or "emulator"."""
    if kind == "emulator":
        try:
            return EmulatedControl(ip)
        except OSError as e:
            raise URError(ip, "control", f"no emulator servo port ({e}); start one with `rio ur emulator`") from e
    from rtde_control import RTDEControlInterface

    try:
        return RTDEControlInterface(ip, float(rate_hz))
    except RuntimeError as e:
        raise URError(ip, "control", f"ur-rtde could not start its control script ({e}); {REMOTE_HINT}") from e
