"""The UR controller's ports, for emulators on loopback addresses of their own (`rio.emulation.
free_loopback`): ur-rtde's receive interface always dials port 30004, so emulators side by side need an
address each. Every port is above 1024: no root needed."""

from __future__ import annotations

from rio.emulation import free_loopback as _free_loopback
from rio.emulation import is_free as _is_free

#: Dashboard, RTDE, and the emulator's servo port (the stand-in for the control script, `control.py`).
DASHBOARD_PORT, RTDE_PORT, SERVO_PORT = 29999, 30004, 30020
PORTS = (DASHBOARD_PORT, RTDE_PORT, SERVO_PORT)


def is_free(host: str) -> bool:
    return _is_free(host, PORTS)


def free_loopback() -> str:
    """A 127.0.0.N whose UR ports are free."""
    return _free_loopback(PORTS)
