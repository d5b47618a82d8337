"""Loopback addresses for emulated controllers. An xArm controller listens on fixed ports (502 and
30001-30003), so emulators side by side need an address each: 127.0.0.N, all of which reach the
loopback interface on Linux (macOS: add each with `sudo ifconfig lo0 alias 127.0.0.N`)."""

from __future__ import annotations

import itertools
import os
import socket

PORTS = (502, 30001, 30002, 30003)
_counter = itertools.count()


def is_free(host: str) -> bool:
    """Nobody (this process or another) listens on the controller's ports at `host`."""
    for port in PORTS:
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host, port))
        except OSError:
            return False
        finally:
            s.close()
    return True


def free_loopback() -> str:
    """A 127.0.0.N address whose controller ports are free (N from 2; spread by process id so parallel
    test processes rarely race for one)."""
    base = os.getpid() * 7
    for _ in range(253):
        host = f"127.0.0.{2 + (base + next(_counter)) % 252}"
        if is_free(host):
            return host
    raise RuntimeError("no free loopback address for an xArm emulator (127.0.0.2-253 all in use)")


PORT_502_HINT = ("the xArm emulator listens on the controller's port 502: run as root, or allow it once with "
                 "`sudo sysctl net.ipv4.ip_unprivileged_port_start=0`")


def can_listen_on_502() -> bool:
    """Whether this process may listen on the controller's port 502 (root, or a system that allows
    unprivileged ports from 0: `sysctl net.ipv4.ip_unprivileged_port_start`)."""
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        s.bind(("127.0.0.1", PORTS[0]))  # the permission check comes before "address in use"
    except PermissionError:
        return False
    except OSError:
        pass
    finally:
        s.close()
    return True
