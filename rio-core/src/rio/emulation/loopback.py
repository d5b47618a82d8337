"""Loopback addresses for emulated controllers. A vendor SDK dials fixed ports (xArm 502 and
30001-30003, UR 29999 and 30004), so emulators side by side need an address each: 127.0.0.N, all of
which reach the loopback interface on Linux (macOS: `sudo ifconfig lo0 alias 127.0.0.N` first).

Station files name fixed addresses (`ur5e-sim` serves its emulator on 127.0.0.2, others on .3 or .10),
so `free_loopback` never hands out 127.0.0.2-31: a test's emulator on a station's address would
answer that station's driver in its place (seen in CI: a UR station's arm connected to the status
test's emulator and its gripper found no URCap socket there)."""

from __future__ import annotations

import itertools
import os
import socket
from collections.abc import Iterable

from rio.machine.parallel import worker_share

_counter = itertools.count()
#: 127.0.0.2 up to this one are left to station files.
STATION_ADDRESSES_END = 31
_FIRST, _LAST = STATION_ADDRESSES_END + 1, 254


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
    """A 127.0.0.N address (N from 32: see the module's docstring) where all of `ports` are free. A
    pytest-xdist worker draws from its own share of them (`rio.machine.parallel`), so two workers never
    race for one; other processes are spread by process id, so that they rarely do."""
    ports = tuple(ports)
    share = worker_share(_FIRST, _LAST)
    base = os.getpid() * 7
    for _ in range(len(share)):
        host = f"127.0.0.{share[(base + next(_counter)) % len(share)]}"
        if is_free(host, ports):
            return host
    raise RuntimeError(f"no loopback address 127.0.0.{share[0]}-{share[-1]} has ports {list(ports)} free for an "
                       "emulator")


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
