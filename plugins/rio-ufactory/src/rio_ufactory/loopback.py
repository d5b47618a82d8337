"""The xArm controller's ports, for emulators on loopback addresses of their own (`rio.emulation.
free_loopback`). Port 502 is privileged: the emulator needs root, or a system that allows unprivileged
ports from 0 (the SDK hard-codes its ports, so they cannot be moved)."""

from __future__ import annotations

from rio.emulation import can_listen
from rio.emulation import free_loopback as _free_loopback
from rio.emulation import is_free as _is_free

PORTS = (502, 30001, 30002, 30003)

PORT_502_HINT = ("the xArm emulator listens on the controller's port 502: run as root, or allow it once with "
                 "`sudo sysctl net.ipv4.ip_unprivileged_port_start=0`")


def is_free(host: str) -> bool:
    return _is_free(host, PORTS)


def free_loopback() -> str:
    return _free_loopback(PORTS)


def can_listen_on_502() -> bool:
    return can_listen(PORTS[0])
