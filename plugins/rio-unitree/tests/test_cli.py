"""`rio unitree check | damp | bridge | debug-mode | stand`: the bring-up check against the bridge, and
what it says when there is nothing to hear; damping reaching the motors; the bridge as its own process,
heard across processes on loopback and stopped cleanly by a signal; releasing the (bridge's stand-in for)
locomotion over the motion switcher RPC, and `stand` ramping the robot to home, refused without --yes or
while locomotion runs."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from rio_unitree.cli import app
from rio_unitree.dds import LOWCMD, LOWSTATE, Participant
from rio_unitree.testing import Tap, publishing
from rio_unitree.tools import check
from rio_unitree.wire import LowState
from typer.testing import CliRunner

from rio.testing import wait_until

runner = CliRunner()


def test_check_hears_the_bridge(make_bridge, domain_id):
    make_bridge()
    out = runner.invoke(app, ["check", "--interface", "lo", "--domain-id", str(domain_id)])
    assert out.exit_code == 0, out.output
    assert "ok: the robot is heard" in out.output and "joints reporting: 29 of 29" in out.output
    assert "mode_machine 5" in out.output and "0 with a wrong CRC" in out.output
    assert "rt/arm_sdk: read by 1" in out.output and "unsigned state" not in out.output
    out = runner.invoke(app, ["check", "--interface", "lo", "--domain-id", str(domain_id), "--json"])
    got = json.loads(out.stdout)
    assert out.exit_code == 0 and got["ok"] and got["problem"] is None and any("29 of 29" in x for x in got["lines"])


def test_check_names_what_is_missing(domain_id):
    out = runner.invoke(app, ["check", "--interface", "lo", "--domain-id", str(domain_id), "--timeout", "0.3"])
    assert out.exit_code == 1 and f"no rt/lowstate on 'lo' (DDS domain {domain_id}) within 0.3 s" in out.output
    assert "--domain-id N" in out.output  # a simulator on its own domain is the usual cause
    report = check("nope0")
    assert not report.ok and "no interface 'nope0'" in report.problem


def test_check_says_a_simulator_s_state_is_unsigned(domain_id):
    """Unitree's unitree_mujoco publishes rt/lowstate with CRC 0 and reads no rt/arm_sdk: `check` hears it
    (not "a bad CRC"), says the driver needs peer = "simulator", and that only control = "lowcmd" works."""
    with Participant(domain_id, "lo") as p, publishing(p.writer(LOWSTATE), LowState().encode(fix_crc=False)):
        out = runner.invoke(app, ["check", "--interface", "lo", "--domain-id", str(domain_id)])
    assert out.exit_code == 0, out.output
    assert "0 with a wrong CRC" in out.output and "unsigned state:" in out.output and 'peer = "simulator"' in out.output
    assert "rt/arm_sdk: nobody reads it" in out.output


def test_damp_makes_the_motors_soft(make_bridge, domain_id):
    bridge = make_bridge()
    out = runner.invoke(app, ["damp", "--interface", "lo", "--domain-id", str(domain_id), "--seconds", "0.5"])
    assert out.exit_code == 0, out.output
    cmd = bridge.lowcmd
    assert cmd is not None and (cmd.kp[:29] == 0).all() and (cmd.kd[:29] > 0).all() and cmd.mode_machine == 5


def test_the_bridge_runs_as_its_own_process_and_stops_on_a_signal(domain_id):
    cmd = [sys.executable, "-m", "rio", "unitree", "bridge", "--domain-id", str(domain_id), "--model", "fallback",
           "--seconds", "60"]
    # physics only, so no OpenGL backend: MUJOCO_GL=egl made `import mujoco` raise where libEGL is not installed
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env={**os.environ, "MUJOCO_GL": "disable"})
    try:
        report = None

        def heard():
            nonlocal report
            report = check("lo", domain_id, timeout_s=1.0)
            return report.ok

        if not wait_until(heard, timeout=30.0, period=0.2):
            proc.kill()
            pytest.fail(f"{report.problem if report else 'no report'}; the bridge said: {proc.communicate()[0]}")
        assert any("29 of 29" in line for line in report.lines)
        t0 = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        out, _ = proc.communicate(timeout=20)
        assert proc.returncode == 0, out
        assert "stopped:" in out and time.monotonic() - t0 < 10
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_debug_mode_releases_the_locomotion_over_the_motion_switcher(make_bridge, domain_id):
    bridge = make_bridge()
    args = ["debug-mode", "--interface", "lo", "--domain-id", str(domain_id)]
    out = runner.invoke(app, [*args, "--check"])
    assert out.exit_code == 0 and "mode: ai" in out.output, out.output
    out = runner.invoke(app, args)  # not a terminal and no --yes: refused, naming the risk
    assert out.exit_code == 1 and "refusing without --yes" in out.output and "falls" in out.output
    assert not bridge.released
    out = runner.invoke(app, [*args, "--yes"])
    assert out.exit_code == 0 and "released: debug mode" in out.output, out.output
    assert bridge.released and (bridge._hold.kp == 0).all()  # the stand-in let go: soft
    out = runner.invoke(app, [*args, "--check"])
    assert "mode: (none: debug mode)" in out.output


def test_debug_mode_without_a_robot_says_so(domain_id):
    out = runner.invoke(app, ["debug-mode", "--interface", "lo", "--domain-id", str(domain_id), "--timeout", "0.3",
                              "--yes"])
    assert out.exit_code == 1 and "no answer from the motion switcher" in out.output and "L2+R2" in out.output


def test_stand_stops_with_damping_when_the_robot_goes_silent(domain_id):
    """A robot whose rt/lowstate stops mid-ramp (a pulled cable): stand stops within its state timeout and
    ends on damping, naming the silence. (A peer that only publishes a state: no motion switcher answers.)"""
    from rio_unitree.commands import is_damping
    from rio_unitree.tools import stand

    result: list = []
    run = threading.Thread(target=lambda: result.append(
        stand("lo", domain_id, seconds=3.0, hold_s=0.5, state_timeout_s=0.25, check_mode_timeout_s=0.2)))
    tap = Tap(domain_id, LOWCMD)
    try:
        with Participant(domain_id, "lo") as p:
            with publishing(p.writer(LOWSTATE), LowState().encode()):
                run.start()
                assert wait_until(lambda: bool(tap.poll()) or bool(tap.samples), timeout=10.0), "stand sent nothing"
            run.join(30)  # the state went quiet a moment into the 3 s ramp
        tap.poll()
    finally:
        tap.close()
    report = result[0]
    assert not report.ok and "rt/lowstate went silent" in report.problem, report
    assert is_damping(tap.samples[-1]), "the last command was not damping"


def test_stand_ramps_a_released_robot_to_home(make_bridge, domain_id):
    from rio_unitree.g1 import HOME, joint_names

    bridge = make_bridge(start_pose={})  # every joint at 0: the stand-in holds it there
    args = ["stand", "--interface", "lo", "--domain-id", str(domain_id), "--seconds", "1.0", "--hold", "0.5"]
    out = runner.invoke(app, args)
    assert out.exit_code == 1 and "refusing without --yes" in out.output and "hang" in out.output
    out = runner.invoke(app, [*args, "--yes"])  # locomotion (the stand-in) still runs: refused
    assert out.exit_code == 1 and "debug-mode" in out.output and bridge.counts.lowcmd == 0, out.output
    released = runner.invoke(app, ["debug-mode", "--interface", "lo", "--domain-id", str(domain_id), "--yes"])
    assert released.exit_code == 0, released.output
    from rio_unitree.tools import stand

    # the ramp is what is tested here (silence has its own test): the bridge, in this process, may pause
    # for longer than the robot's 0.25 s on a loaded machine (0.39 s seen beside another test worker)
    report = stand("lo", domain_id, seconds=1.0, hold_s=0.5, state_timeout_s=2.0)
    assert report.ok, report.problem
    home = np.array([HOME.get(name, 0.0) for name in joint_names(29)])
    assert np.abs(report.start - home).max() > 0.3  # from where the released (soft) robot sagged to
    assert report.error < 0.08, report.error  # home, within the gravity sag of the driver's gains
    cmd = bridge.lowcmd  # and soft at the end
    assert cmd is not None and (cmd.kp[:29] == 0).all() and (cmd.kd[:29] > 0).all()
    assert report.sent > 100


def test_the_bridge_plays_inspire_hands_on_request_and_refuses_a_second_kind(domain_id):
    pytest.importorskip("rio_sim")  # model "hands": rio-sim's G1 with Dex3-1 hands
    res = runner.invoke(app, ["bridge", "--domain-id", str(domain_id), "--model", "hands", "--inspire",
                              "--seconds", "1"])
    assert res.exit_code == 1 and "Dex3-1 hands already" in res.output, res.output
    res = runner.invoke(app, ["bridge", "--domain-id", str(domain_id), "--model", "fallback", "--inspire",
                              "--seconds", "0.5"])
    assert res.exit_code == 0, res.output
    assert "Inspire hands" in res.output, res.output
