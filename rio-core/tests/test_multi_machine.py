"""A station on two machines, emulated on one: two network namespaces joined by a veth pair
(`rio.machine.netns`). The robot side runs `rio serve STATION --machine robot`, the other side the control
loop (`rio teleop STATION`), over zmq and zenoh with the station's keys, each side with its own home
directory holding its own keys, as two computers would. Then the cable is pulled: the loop side must
stop, its summary naming a node, exit status 4; the robot side must hold and say so, and once the link is back a
new run must connect to the same, never restarted, nodes. Needs Linux and root (CI has both)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from rio.machine import keys, netns

pytestmark = pytest.mark.slow  # every test here runs for tens of seconds (a module fixture builds, installs or records)

STATION = """
name = "two-{mw}"
rate_hz = 30
[middleware]
name = "{mw}"
keys = "~/keys"
[embodiment]
action_space = "eef_pose"
[machines.robot]
address = "{robot}"
nodes = ["arm", "wrist_camera"]
port = 7600
[components.arm]
driver = "rio.fake_arm"
dof = 3
[components.wrist_camera]
driver = "rio.fake_camera"
width = 64
height = 48
[components.teleop]
driver = "teleop.scripted"
script = "square"
"""


@pytest.fixture(scope="module")
def net():
    why = netns.available()
    if why:
        pytest.skip(f"multi-machine tests need two network namespaces: {why}")
    with netns.TwoMachines() as n:
        yield n


@pytest.fixture(scope="module")
def homes(tmp_path_factory):
    """A home directory per machine, each with only its own keys at ~/keys."""
    root = tmp_path_factory.mktemp("machines")
    keys.generate(root / "made", ["robot", "workstation"])
    out = {}
    for name in ("robot", "workstation"):
        home = root / name
        home.mkdir()
        shutil.copytree(root / "made" / name, home / "keys")
        out[name] = home
    return out


def _env(home: Path) -> dict[str, str]:
    return {**os.environ, "HOME": str(home), "PYTHONUNBUFFERED": "1", "COLUMNS": "200"}


class _Lines:
    """A process's stderr+stdout lines, collected by a thread (the test waits for some of them)."""

    def __init__(self, proc: subprocess.Popen):
        self.proc, self.lines = proc, []
        self._t = threading.Thread(target=self._read, daemon=True)
        self._t.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.append(line)

    def wait_for(self, text: str, timeout: float) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if any(text in ln for ln in self.lines):
                return
            if self.proc.poll() is not None:
                time.sleep(0.2)
                break
            time.sleep(0.1)
        raise AssertionError(f"'{text}' not seen in {timeout} s; output:\n{self.text}")

    @property
    def text(self) -> str:
        return "".join(self.lines)


def _rio(side: netns.Side, home: Path, *args: str, **kw) -> subprocess.Popen:
    return side.popen([sys.executable, "-m", "rio", *args], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                      stdin=subprocess.DEVNULL, text=True, env=_env(home), **kw)


@pytest.mark.parametrize("mw", ["zmq", "zenoh"])
def test_a_station_on_two_machines_survives_a_pulled_cable(net, homes, tmp_path, mw):
    station = tmp_path / "two.toml"
    station.write_text(STATION.format(mw=mw, robot=net.a.address))
    serve = _rio(net.a, homes["robot"], "serve", str(station), "--machine", "robot")
    robot = _Lines(serve)
    try:
        robot.wait_for("serving arm, wrist_camera", timeout=90)

        # 1. a run over the link: the arm follows, the camera's frames are recorded
        run = net.b.run([sys.executable, "-m", "rio", "teleop", str(station), "--duration", "3", "--json",
                         "--record", str(tmp_path / "data")],
                        capture_output=True, text=True, env=_env(homes["workstation"]), timeout=180)
        assert run.returncode == 0, run.stdout + run.stderr
        summary = json.loads(run.stdout)
        assert summary["followed"] is True, summary
        from rio.recording import Dataset

        ep = Dataset(str(tmp_path / "data")).episodes[0]
        assert ep["length"] > 30 and ep["cameras"]["wrist.rgb"]["frames"] > 10, ep

        # 2. the cable is pulled mid-run: the loop stops naming a node, the robot holds and says so
        loop = _rio(net.b, homes["workstation"], "teleop", str(station), "--duration", "120")
        lines = _Lines(loop)
        lines.wait_for("starting station", timeout=90)
        time.sleep(4)  # moving by now
        net.cut()
        try:
            code = loop.wait(timeout=60)
        finally:
            net.mend()
        time.sleep(0.5)
        assert code == 4, lines.text  # a node stopped during the run (rio.cli.exit_status)
        err = [ln for ln in lines.lines if ln.startswith("  ERROR: node ")]  # at the top of the summary
        assert len(err) == 1 and ("'arm'" in err[0] or "'wrist_camera'" in err[0]), lines.text
        assert "Traceback" not in lines.text
        robot.wait_for("holding", timeout=30)
        assert serve.poll() is None, robot.text  # the nodes were not stopped by the loop side's loss

        # 3. the link is back: a new run connects to the same nodes (never restarted)
        again = net.b.run([sys.executable, "-m", "rio", "teleop", str(station), "--duration", "2", "--json"],
                          capture_output=True, text=True, env=_env(homes["workstation"]), timeout=180)
        assert again.returncode == 0, again.stdout + again.stderr
        assert json.loads(again.stdout)["followed"] is True
        assert robot.text.count("serving arm, wrist_camera") == 1
    finally:
        serve.send_signal(2)
        try:
            serve.wait(timeout=30)
        except subprocess.TimeoutExpired:
            serve.kill()
    assert serve.returncode == 130, robot.text
    assert "Traceback" not in robot.text


@pytest.mark.parametrize("mw", ["zmq", "zenoh"])
def test_a_loop_side_without_the_keys_is_refused(net, homes, tmp_path, mw):
    """The robot side serves with the station's keys; a machine holding keys from another CA (as a
    stranger would, with the station file in hand) gets no state and cannot command the arm."""
    station = tmp_path / "two.toml"
    station.write_text(STATION.format(mw=mw, robot=net.a.address))
    serve = _rio(net.a, homes["robot"], "serve", str(station), "--machine", "robot")
    robot = _Lines(serve)
    stranger = tmp_path / "stranger"
    stranger.mkdir()
    keys.generate(tmp_path / "other", ["robot", "workstation"])
    shutil.copytree(tmp_path / "other" / "workstation", stranger / "keys")
    try:
        robot.wait_for("serving arm, wrist_camera", timeout=90)
        r = net.b.run([sys.executable, "-m", "rio", "teleop", str(station), "--duration", "2"],
                      capture_output=True, text=True, env=_env(stranger), timeout=120)
        assert r.returncode != 0, r.stdout + r.stderr
        last = r.stderr.strip().splitlines()[-1]
        assert "Traceback" not in r.stderr and last.startswith("error: node '") and ("authentication" in last
                                                                                  or "certificate" in last), r.stderr
        assert serve.poll() is None
    finally:
        serve.send_signal(2)
        serve.wait(timeout=30)
