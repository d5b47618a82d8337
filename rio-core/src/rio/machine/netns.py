"""Two machines on one: two Linux network namespaces joined by a veth pair.

What a multi-machine station needs tested (its nodes reached over a real link that can be cut, not
over loopback) without a second computer: each namespace has its own interfaces, routes and ports,
so a node bound to one side's address is reachable from the other side only through the veth link,
and `cut()` takes that link down as an unplugged cable would. Needs Linux and root (CAP_NET_ADMIN);
`available()` says why not otherwise. Used by the multi-machine tests and `bench/multi_machine.py`.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field

from rio.machine.system_needs import SystemNeed

#: The `ip` command that makes the namespaces (not in a minimal Debian, such as a container image).
IPROUTE2 = SystemNeed("iproute2", program="ip")
#: `tc`, which shapes the link (`TwoMachines.shape`); iproute2 ships it too.
TC = SystemNeed("iproute2", program="tc")


def available() -> str | None:
    """None when namespaces can be made here, else why not (a reason for a skip)."""
    if not sys.platform.startswith("linux"):
        return "network namespaces are Linux only"
    missing = IPROUTE2.missing()
    if missing is not None:
        return missing
    if os.geteuid() != 0:
        return "creating network namespaces needs root"
    probe = f"rio-probe-{os.getpid()}"
    r = subprocess.run(["ip", "netns", "add", probe], capture_output=True, text=True)
    if r.returncode != 0:
        return f"`ip netns add` failed: {r.stderr.strip()}"
    subprocess.run(["ip", "netns", "del", probe], capture_output=True)
    return None


def _ip(*args: str) -> None:
    r = subprocess.run(["ip", *args], capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)}: {r.stderr.strip()}")


@dataclass
class Side:
    """One end: a namespace, its veth interface and address."""

    ns: str
    dev: str
    address: str

    def command(self, argv: Sequence[str]) -> list[str]:
        """`argv` run inside this side's namespace."""
        return ["ip", "netns", "exec", self.ns, *argv]

    def popen(self, argv: Sequence[str], **kw) -> subprocess.Popen:  # noqa: ANN003 - Popen's keywords
        return subprocess.Popen(self.command(argv), **kw)

    def run(self, argv: Sequence[str], **kw) -> subprocess.CompletedProcess:  # noqa: ANN003 - run's keywords
        return subprocess.run(self.command(argv), **kw)


@dataclass
class TwoMachines:
    """`with TwoMachines() as net:` `net.a` and `net.b` (10.231.<n>.1 and .2), `net.cut()`, `net.mend()`.
    Everything is removed on exit, processes still running in a namespace included."""

    subnet: int = field(default_factory=lambda: os.getpid() % 250 + 1)
    a: Side = field(init=False)
    b: Side = field(init=False)

    def __post_init__(self) -> None:
        tag = f"{os.getpid() % 100000}"
        self.a = Side(f"rio-a{tag}", f"rioa{tag}", f"10.231.{self.subnet}.1")
        self.b = Side(f"rio-b{tag}", f"riob{tag}", f"10.231.{self.subnet}.2")

    def __enter__(self) -> TwoMachines:
        try:
            for s in (self.a, self.b):
                _ip("netns", "add", s.ns)
            _ip("link", "add", self.a.dev, "type", "veth", "peer", "name", self.b.dev)
            for s in (self.a, self.b):
                _ip("link", "set", s.dev, "netns", s.ns)
                _ip("-n", s.ns, "addr", "add", f"{s.address}/24", "dev", s.dev)
                _ip("-n", s.ns, "link", "set", s.dev, "up")
                _ip("-n", s.ns, "link", "set", "lo", "up")
        except BaseException:
            self.__exit__()
            raise
        return self

    def shape(self, rate: str | None = None, delay_ms: float = 0.0, loss_pct: float = 0.0) -> str:
        """Make the link a slower one, both ways, with `tc`: `rate` ("1gbit", "100mbit"), one-way `delay_ms`,
        random `loss_pct` (netem). A kernel without netem (some containers) gets the rate alone (tbf), and
        the answer says so: it describes what was applied. `shape()` alone restores the bare veth."""
        applied = "bare veth"
        for s in (self.a, self.b):
            subprocess.run(["ip", "netns", "exec", s.ns, "tc", "qdisc", "del", "dev", s.dev, "root"],
                           capture_output=True)
            if rate is None and not delay_ms and not loss_pct:
                continue
            netem = ["delay", f"{delay_ms}ms"] + (["rate", rate] if rate else []) + \
                (["loss", f"{loss_pct}%"] if loss_pct else [])
            # a queue of ~0.2 s at the rate (netem's default, 1000 packets, is 12 ms at 1 Gbit/s)
            r = self._tc(s, "netem", *netem, "limit", "20000")
            applied = f"netem {' '.join(netem)}"
            if r.returncode != 0 and "unknown" in r.stderr and rate:
                r = self._tc(s, "tbf", "rate", rate, "burst", "256kb", "latency", "200ms")
                applied = f"tbf rate {rate} (no netem in this kernel: no delay, no loss)"
            if r.returncode != 0:
                raise RuntimeError(f"tc on {s.dev}: {r.stderr.strip()}")
        return applied

    @staticmethod
    def _tc(side: Side, kind: str, *args: str) -> subprocess.CompletedProcess:
        return subprocess.run(["ip", "netns", "exec", side.ns, "tc", "qdisc", "add", "dev", side.dev, "root", kind,
                               *args], capture_output=True, text=True)

    def tx_bytes(self, side: Side) -> int:
        """Bytes `side` has sent on its end of the link (its interface's counter)."""
        r = side.run(["cat", f"/sys/class/net/{side.dev}/statistics/tx_bytes"], capture_output=True, text=True)
        return int(r.stdout.strip() or 0)

    def cut(self) -> None:
        """Unplug the cable (both ends down: nothing gets through either way)."""
        for s in (self.a, self.b):
            _ip("-n", s.ns, "link", "set", s.dev, "down")

    def mend(self) -> None:
        for s in (self.a, self.b):
            _ip("-n", s.ns, "link", "set", s.dev, "up")

    def __exit__(self, *exc: object) -> None:
        for s in (self.a, self.b):
            pids = subprocess.run(["ip", "netns", "pids", s.ns], capture_output=True, text=True).stdout.split()
            for pid in pids:
                try:
                    os.kill(int(pid), 9)
                except (ProcessLookupError, ValueError):
                    pass
            subprocess.run(["ip", "netns", "del", s.ns], capture_output=True)
