"""The DH AG-95 / AG-105-145 driver end to end through minimalmodbus on a pty: initialization, widths,
force and speed reaching the registers, object caught and dropped, a lost initialization stopping it
with a named error, and the reset."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest
from rio_robotiq.dh.driver import DhGripper
from rio_robotiq.dh.registers import FORCE, POSITION, SPEED
from rio_robotiq.errors import ActivationError, CommunicationError, GripperFault

from rio.testing import lifecycle

PERMILLE = 0.095 / 1000  # one position step of an AG-95 (m)
TOL = 2 * PERMILLE


@contextmanager
def driven(line, runner, **config: Any) -> Iterator[tuple[Any, Any]]:
    """The driver open on the emulated `line` (with `config`), and a runner ticking it."""
    with lifecycle(DhGripper(port=line.port, **config)) as g:
        yield g, runner(g)


def test_open_initializes_and_skips_it_when_done(dh_rtu):
    regs = dh_rtu.device
    assert regs.init_state == 0
    with lifecycle(DhGripper(port=dh_rtu.port)) as g:
        assert regs.init_state == 1
        s = g.cycle()
        assert s["width"] == pytest.approx(0.095) and s["enabled"] and not s["object_detected"]
    regs.handle(bytes.fromhex("01 06 01 03 01 F4"))  # move to half open behind the driver's back
    time.sleep(1.0)
    with lifecycle(DhGripper(port=dh_rtu.port)) as g:  # initialized: no initialization (it would open fully)
        assert g.cycle()["width"] == pytest.approx(0.0475, abs=TOL)


def test_moves_to_a_width_and_both_ends(dh_rtu, runner):
    with driven(dh_rtu, runner) as (g, r):
        for width in (0.03, 0.0, 0.095, 0.06):
            r.move(width)
            r.until(lambda s, w=width: abs(s["width"] - w) <= TOL)
            assert dh_rtu.device.holding[POSITION] == round(width / 0.095 * 1000)


def test_force_and_speed_reach_the_registers(dh_rtu, runner):
    regs = dh_rtu.device
    with driven(dh_rtu, runner, speed=0.05, force=80.0) as (g, r):
        r.move(0.05)
        r.until(lambda s: abs(s["width"] - 0.05) <= TOL)
        assert regs.holding[SPEED] == round(0.05 / (0.095 / 0.7) * 100)  # 37 %
        assert regs.holding[FORCE] == 50  # 80 N of 160 N
        assert regs.force == pytest.approx(80.0) and regs.speed == pytest.approx(0.05, rel=0.02)
        r.move(0.02, force=10.0)  # below the gripper's 20 %: clipped, never refused
        r.until(lambda s: abs(s["width"] - 0.02) <= TOL)
        assert regs.holding[FORCE] == 20


def test_without_a_force_half_of_the_maximum(dh_rtu, runner):
    with driven(dh_rtu, runner) as (g, r):
        r.move(0.04)
        r.until(lambda s: abs(s["width"] - 0.04) <= TOL)
        assert dh_rtu.device.holding[FORCE] == 50 and dh_rtu.device.holding[SPEED] == 100


def test_object_caught_then_dropped(dh_rtu, runner):
    regs = dh_rtu.device
    regs.fingers.object_width = 0.04
    with driven(dh_rtu, runner) as (g, r):
        r.move(0.0, seconds=0.3)
        s = r.until(lambda s: s["object_detected"])
        assert s["width"] == pytest.approx(0.04, abs=TOL) and not s["object_dropped"]
        regs.fingers.object_width = None  # it slips out
        s = r.until(lambda s: s["object_dropped"])
        assert not s["object_detected"] and s["width"] == pytest.approx(0.0, abs=TOL)


def test_lost_initialization_stops_it_with_a_named_error_and_resets(dh_rtu, runner):
    regs = dh_rtu.device
    with driven(dh_rtu, runner) as (g, r):
        r.closing(4.0, below=0.09)
        regs.power_cycle()
        with pytest.raises(GripperFault) as ei:
            r.until(lambda s: False, timeout=5.0)
        assert dh_rtu.port in str(ei.value) and "lost its initialization" in str(ei.value)
        assert "reset_fault()" in str(ei.value) and g.commander.holding
        assert g.reset_fault() is True
        assert regs.init_state == 1
        r.move(0.03)
        r.until(lambda s: abs(s["width"] - 0.03) <= TOL)


def test_disable_and_enable_hold_the_measured_position(dh_rtu, runner):
    regs = dh_rtu.device
    with driven(dh_rtu, runner) as (g, r):
        r.closing(3.0, below=0.08)
        g.disable()
        stopped = regs.position
        time.sleep(0.2)
        assert regs.position == pytest.approx(stopped, abs=TOL)
        g.enable()
        assert r.settle(0.2)["width"] == pytest.approx(stopped, abs=TOL)


def test_reads_with_function_3_writes_with_function_6(dh_rtu, runner):
    with driven(dh_rtu, runner) as (g, r):
        r.move(0.05)
        r.until(lambda s: abs(s["width"] - 0.05) <= TOL)
    assert set(dh_rtu.device.requests) == {3, 6}


def test_initialization_timeout_and_dead_line_name_the_port(dh_rtu):
    regs = dh_rtu.device
    regs.fingers.position = regs.fingers.goal = 0.0  # closed, and the initialization run crawls
    regs.init_speed = 1e-4
    with pytest.raises(ActivationError, match="did not finish initializing") as ei:
        DhGripper(port=dh_rtu.port, init_timeout_s=0.3).open()
    assert dh_rtu.port in str(ei.value)
    dh_rtu.silent = True
    with pytest.raises(CommunicationError, match="slave id 1"):
        DhGripper(port=dh_rtu.port, timeout_s=0.05).open()


def test_the_ag105_is_the_145_mm_model():
    with lifecycle(DhGripper(port="emulator", model="ag105")) as g:
        assert g.cycle()["max_width"] == pytest.approx(0.145)
