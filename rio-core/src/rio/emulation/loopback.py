"""Loopback addresses for emulated controllers. A vendor SDK dials fixed ports (xArm 502 and
30001-30003, UR 29999 and 30004), so emulators side by side need an address each: 127.0.0.N, all of
which reach the loopback interface on Linux (macOS: `sudo ifconfig lo0 alias 127.0.0.N` first)."""

from __future__ import annotations

import itertools
import os
import socket
from collections.abc import Iterable

_counter = itertools.count()


def is_free(host: str, ports: Iterable[int]) -> bool:
    """Nobody (this process or another) listens on any of `ports` at `host`."""
    for port in ports:
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host, port))
        except OSError:
            return False
        finally:
            s.close()
    return True


def free_loopback(ports: Iterable[int]) -> str:
    """A 127.0.0.N address (N from 2) where all of `ports` are free; spread by process id so parallel
    test processes rarely race for one."""
    ports = tuple(ports)
    base = os.getpid() * 7
    for _ in range(253):
        host = f"127.0.0.{2 + (base + next(_counter)) % 252}"
        if is_free(host, ports):
            return host
    raise RuntimeError(f"no loopback address 127.0.0.2-253 has ports {list(ports)} free for an emulator")


def can_listen(port: int) -> bool:
    """Whether this process may listen on `port` (below 1024: root, or a system that allows unprivileged
    ports from 0, `sysctl net.ipv4.ip_unprivileged_port_start`)."""
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        s.bind(("127.0.0.1", port))  # the permission check comes before "address in use"
    except PermissionError:
        return False
    except OSError:
        pass
    finally:
        s.close()
    return True
