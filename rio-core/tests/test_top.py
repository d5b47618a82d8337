"""`rio top`: a running station's nodes as another process sees them — each node's publishing rate and
sample age read from its ring buffer in place (shm), its process's CPU and memory — through the real
command line, against a station served by this test."""

from __future__ import annotations

import json
import subprocess
import sys
import uuid

import pytest

from rio.runtime.manager import ServerManager
from rio.station import make_station, parse_station


def _station(mw: str) -> tuple[str, dict]:
    name = f"top-{uuid.uuid4().hex[:6]}"
    return name, {"name": name, "rate_hz": 50, "middleware": {"name": mw},
                  "components": {"arm": {"driver": "rio.fake_arm", "dof": 3, "rate_hz": 100.0}}}


def _top(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "rio", "top", *args], capture_output=True, text=True, timeout=120,
                          stdin=subprocess.DEVNULL)


@pytest.mark.slow
def test_top_reads_a_shm_stations_rates_ages_and_processes():
    pytest.importorskip("psutil")
    name, data = _station("shm")
    servers, _clients, _env = make_station(parse_station(data))
    with ServerManager(servers, station=name) as manager:
        out = _top(name, "--once", "--json", "--interval", "1.5")
        assert out.returncode == 0, out.stderr
        rows = json.loads(out.stdout)
        arm = next(r for r in rows if r["node"] == "arm")
        assert arm["pid"] == manager.pids()["arm"] and arm["middleware"] == "shm"
        assert 30 < arm["rate_hz"] < 200, arm  # published at 100 Hz; loose for a loaded machine
        assert 0 <= arm["age_ms"] < 1000 and arm["cpu_pct"] is not None and arm["rss_mb"] > 10, arm
        text = _top(name, "--once", "--interval", "0.5").stdout
        assert name in text and "arm" in text and "rate Hz" in text
    assert _top(name, "--once", "--interval", "0.1").returncode == 1  # stopped: gone from the list


def test_top_shows_thread_nodes_by_their_process_only():
    name, data = _station("thread")
    servers, _clients, _env = make_station(parse_station(data))
    with ServerManager(servers, station=name):
        rows = json.loads(_top(name, "--once", "--json", "--interval", "0.3").stdout)
    assert [r["note"] for r in rows] == ["thread node: process only"] and rows[0]["rate_hz"] is None
