"""`rio top`: the running stations of this machine, live — per node: publishing rate, the age of its
newest sample, CPU and memory of its process — like `htop` for a robot station.

A `ServerManager` leaves `station.json` in its run directory (`rio.runtime.manager.MANIFEST`): the station,
its nodes, their processes, and where the middleware shares them (`shm`) a reference to each node's
ring buffer (`rio.runtime.ring_ref`). `rio top` opens those rings read-only, in place, and watches their
counters and newest timestamps; it never sends a request and never takes a lock, so watching costs
the station nothing. Nodes on the thread middleware (threads of the manager's process) and on network
middlewares show their process only: their rings cannot be read from another process.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from rio import clock
from rio.machine import host
from rio.profiling.stats import ProcessReading


def running_stations(station: str | None = None, tmp: str | None = None) -> list[dict[str, Any]]:
    """Manifests of the stations running on this machine (their manager still alive), optionally only
    those named `station`."""
    from rio.runtime.manager import MANIFEST

    out = []
    for path in sorted(Path(tmp or host.run_dir_base()).glob(f"rio-*/{MANIFEST}")):
        try:
            m = json.loads(path.read_text())
        except (OSError, ValueError):
            continue  # being written, or being removed
        if host.pid_alive(int(m.get("pid", -1))) and (station is None or m.get("station") == station):
            out.append(m)
    return out


class _Watched:
    """One node: its ring (when readable here) and its process."""

    def __init__(self, station: str, node: dict[str, Any], psutil: Any):
        self.station, self.name, self.mw, self.pid = station, node["name"], node["middleware"], int(node["pid"])
        self.ring: Any = None
        self.note = ""
        if node.get("ring") is not None and node["middleware"] != "thread":
            from rio.runtime.ring_ref import SharedRing

            try:
                self.ring = SharedRing(node["ring"])
            except Exception as e:  # gone meanwhile, or not readable from here
                self.note = f"ring not readable ({type(e).__name__})"
        elif node.get("ring") is None:
            shares = node["middleware"] in ("shm", "thread")
            self.note = "no state" if shares else f"{node['middleware']}: process only"
        else:
            self.note = "thread node: process only"
        self.proc = ProcessReading(self.pid, psutil) if psutil is not None else None
        self.rate = clock.CountRate(lambda: None if self.ring is None else int(self.ring.ring_buffer.count))

    def row(self) -> dict[str, Any]:
        rate = self.rate.rate()
        age_ms = None
        if rate is not None:
            rb = self.ring.ring_buffer
            if rb.count > 0:
                age_ms = round((clock.now() - float(rb.get()["timestamp"])) * 1000, 2)
        reading = self.proc.read() if self.proc is not None else None
        cpu, rss = (round(reading[0], 1), round(reading[1], 1)) if reading is not None else (None, None)
        return {"station": self.station, "node": self.name, "middleware": self.mw, "pid": self.pid,
                "rate_hz": None if rate is None else round(rate, 1), "age_ms": age_ms, "cpu_pct": cpu,
                "rss_mb": rss, "note": self.note}

    def close(self) -> None:
        if self.ring is not None:
            self.ring.close()
            self.ring = None


class StationTop:
    """Watch the nodes of the running stations (`station`: only that one); `rows()` after each interval."""

    def __init__(self, station: str | None = None):
        try:
            import psutil
        except ImportError:
            psutil = None
        self.psutil = psutil
        self.watched = [_Watched(m["station"], n, psutil) for m in running_stations(station) for n in m["nodes"]]

    def rows(self) -> list[dict[str, Any]]:
        return [w.row() for w in self.watched]

    def close(self) -> None:
        for w in self.watched:
            w.close()

    def __enter__(self) -> StationTop:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def format_rows(rows: list[dict[str, Any]], cpu_note: bool) -> str:
    def f(v: Any, spec: str) -> str:
        return "-" if v is None else format(v, spec)

    head = (f"{'station':16s} {'node':16s} {'mw':6s} {'pid':>7s} {'rate Hz':>8s} {'age ms':>8s} {'CPU %':>6s} "
            f"{'RSS MB':>7s}")
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(f"{r['station'][:16]:16s} {r['node'][:16]:16s} {r['middleware'][:6]:6s} {r['pid']:7d} "
                     f"{f(r['rate_hz'], '8.1f')} {f(r['age_ms'], '8.2f')} {f(r['cpu_pct'], '6.1f')} "
                     f"{f(r['rss_mb'], '7.1f')}" + (f"  {r['note']}" if r["note"] else ""))
    if cpu_note:
        lines.append("(CPU and memory need psutil: pip install 'rio-core[profile]')")
    return "\n".join(lines)


__all__ = ["running_stations", "StationTop", "format_rows"]
