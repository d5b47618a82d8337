"""The live status line of interactive runs (`rio.loop.status`): what it shows, that it updates in place and
puts events above itself, and that `rio teleop` draws it in a terminal (a pseudo-terminal here) but not with
`--quiet` or when its output is not a terminal."""

from __future__ import annotations

import io
import os
import pty
import re
import select
import subprocess
import sys
import time

import numpy as np
from rich.console import Console

from rio.loop.control_loop import Tick
from rio.loop.status import StatusLine
from rio.schema import SingleArmObs, Step
from rio.testing import fake_eef_station


def _tick(k: int, t: float, mode: str, x: float) -> Tick:
    obs = SingleArmObs(proprio=np.zeros(8), proprio_eef=np.array([x, 0.0, 0.1, 1, 0, 0, 0]), gripper_width=0.025)
    tick = Tick(t, t + 0.04, 0.0, k, True, None, None, step=Step(k, obs, None, None), lateness=0.0004)
    tick.info["mode"] = mode
    return tick


def test_the_line_shows_the_tool_gripper_mode_rate_and_recording_and_puts_events_above(monkeypatch):
    out = io.StringIO()
    console = Console(file=out, force_terminal=True, width=200, color_system=None)
    now = [0.0]
    monkeypatch.setattr("rio.loop.status.clock.now", lambda: now[0])
    with StatusLine(console, recording="data/pick episode 3", refresh_hz=4) as line:
        for k in range(40):
            now[0] = k * 0.025  # 40 Hz ticks
            line(_tick(k, now[0], "translation" if k < 20 else "rotation", 0.2 + 0.001 * k))
        text = line.text(_tick(40, 1.0, "rotation", 0.24))
    assert "tool (+0.240 +0.000 +0.100) m" in text and "gripper 25 mm" in text and "mode rotation" in text
    assert "REC data/pick episode 3" in text
    rate = float(re.search(r"([\d.]+) Hz", text).group(1))
    assert abs(rate - 40.0) < 0.5 and "late p99 0.4 ms" in text
    drawn = out.getvalue()
    assert drawn.count("\n") >= 1 and "mode: rotation" in drawn  # the change, as a line of its own
    redraws = drawn.count("Hz")
    assert 3 <= redraws <= 6, drawn  # redrawn in place at ~4 Hz over a second, not once per tick


def _station(tmp_path) -> str:
    path = tmp_path / "st.toml"
    path.write_text(fake_eef_station("status", 'driver = "rio.fake_teleop"\ntwist = [0.02, 0, 0, 0, 0, 0]\n'))
    return str(path)


def _in_a_terminal(*args: str, timeout: float = 90) -> str:
    """`rio ARGS` with stdout and stderr on a pseudo-terminal, as a person runs it; all it wrote."""
    master, slave = pty.openpty()
    env = {**os.environ, "COLUMNS": "160", "TERM": "xterm"}
    proc = subprocess.Popen([sys.executable, "-m", "rio", *args], stdin=subprocess.DEVNULL, stdout=slave,
                            stderr=slave, env=env)
    os.close(slave)
    chunks, deadline = [], time.monotonic() + timeout
    while time.monotonic() < deadline:
        r, _, _ = select.select([master], [], [], 0.5)
        if r:
            try:
                data = os.read(master, 65536)
            except OSError:  # the child closed the terminal
                break
            if not data:
                break
            chunks.append(data)
        elif proc.poll() is not None:
            break
    proc.wait(10)
    os.close(master)
    return b"".join(chunks).decode(errors="replace")


def test_rio_teleop_draws_the_line_in_a_terminal_and_not_when_quiet(tmp_path):
    station = _station(tmp_path)
    seen = _in_a_terminal("teleop", station, "--duration", "2.5")
    assert re.search(r"\d+\.\d s \| +[\d.]+ Hz, late p99", seen), seen[-2000:]
    assert "tool (+" in seen and "mode translation" in seen
    assert "teleop on 'status'" in seen  # the summary is printed once the line is gone
    quiet = _in_a_terminal("teleop", station, "--duration", "1", "--quiet")
    assert "teleop on 'status'" in quiet and not re.search(r"Hz, late p99", quiet)


def test_no_line_when_the_output_is_not_a_terminal(tmp_path):
    r = subprocess.run([sys.executable, "-m", "rio", "teleop", _station(tmp_path), "--duration", "1"],
                       capture_output=True, text=True, timeout=90, stdin=subprocess.DEVNULL)
    assert r.returncode == 0, r.stderr
    assert "late p99" not in r.stdout + r.stderr and "teleop on 'status'" in r.stdout
