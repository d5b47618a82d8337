"""The Robotiq driver end to end on both transports (Modbus RTU through minimalmodbus on a pty, the
URCap socket), against the same emulated 2F-85: activation, widths, speed and force reaching the
registers, object detection, faults stopping the fingers with a named error, fault reset."""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass
from typing import Any

import pytest
from rio_robotiq.emulator import ModbusRtuDevice, RobotiqRegisters, UrcapServer
from rio_robotiq.errors import ActivationError, CommunicationError, RobotiqFault
from rio_robotiq.models import robotiq_counts
from rio_robotiq.robotiq.driver import RobotiqGripper, RobotiqUrcapGripper

from rio.testing import lifecycle, wait_until

COUNT = 0.085 / 255  # one position count of a 2F-85 (m)


@dataclass
class Bench:
    transport: str
    regs: RobotiqRegisters
    where: str
    device: Any

    def make(self, **config: Any) -> Any:
        if self.transport == "rtu":
            return RobotiqGripper(port=self.device.port, **config)
        return RobotiqUrcapGripper(ip=self.device.host, port=self.device.port, **config)


@pytest.fixture(params=["rtu", "urcap"])
def bench(request):
    regs = RobotiqRegisters("2f85")
    if request.param == "rtu":
        with ModbusRtuDevice(regs) as dev:
            yield Bench("rtu", regs, dev.port, dev)
    else:
        with UrcapServer(regs) as srv:
            yield Bench("urcap", regs, f"{srv.host}:{srv.port}", srv)


def test_open_activates_a_reset_gripper(bench):
    assert not bench.regs.activated
    with lifecycle(bench.make()) as g:
        assert bench.regs.activated and bench.regs.rGTO == 1  # activated, and enabled: following
        s = g.cycle()
        assert s["width"] == pytest.approx(0.085) and s["fault"] == 0 and not s["object_detected"]
        assert s["enabled"] and s["max_width"] == pytest.approx(0.085)


def test_an_activated_gripper_is_not_activated_again(bench):
    regs = bench.regs
    regs.set_request(rACT=1)
    assert wait_until(lambda: regs.activated)
    regs.set_request(rGTO=1, rPR=128, rSP=255)
    assert wait_until(lambda: abs(regs.position - 0.085 * (1 - 128 / 255)) < 1e-6)
    regs.activation_s = 60.0  # re-activating would now time out
    with lifecycle(bench.make(activation_timeout_s=2.0)) as g:
        assert g.cycle()["width"] == pytest.approx(regs.position, abs=COUNT)


def test_moves_to_a_width_and_to_both_ends(bench, runner):
    with lifecycle(bench.make()) as g:
        r = runner(g)
        for width in (0.03, 0.085, 0.0, 0.0425):
            r.move(width)
            r.until(lambda s, w=width: abs(s["width"] - w) <= COUNT)
            assert bench.regs.rPR == robotiq_counts(width, 0.085)
            assert bench.regs.position == pytest.approx(width, abs=COUNT)


def test_speed_and_force_reach_the_registers(bench, runner):
    with lifecycle(bench.make(speed=0.05, force=100.0)) as g:
        r = runner(g)
        r.move(0.05)
        r.until(lambda s: abs(s["width"] - 0.05) <= COUNT)
        assert bench.regs.speed == pytest.approx(0.05, abs=0.13 / 255)
        assert bench.regs.force == pytest.approx(100.0, abs=215 / 255)
        r.move(0.02, force=200.0)  # a request's force replaces the station's
        r.until(lambda s: abs(s["width"] - 0.02) <= COUNT)
        assert bench.regs.force == pytest.approx(200.0, abs=215 / 255)


def test_without_a_force_the_middle_of_the_range(bench, runner):
    with lifecycle(bench.make()) as g:
        r = runner(g)
        r.move(0.04)
        r.until(lambda s: abs(s["width"] - 0.04) <= COUNT)
        assert bench.regs.rFR == 128 and bench.regs.rSP == 255


def test_closing_on_an_object_detects_it_at_its_width(bench, runner):
    bench.regs.fingers.object_width = 0.031
    with lifecycle(bench.make(force=50.0)) as g:
        r = runner(g)
        r.move(0.0, seconds=0.3)
        s = r.until(lambda s: s["object_detected"])
        assert s["width"] == pytest.approx(0.031, abs=COUNT)
        s = r.settle(0.2)
        assert s["object_detected"] and s["width"] == pytest.approx(0.031, abs=COUNT)
        if bench.transport == "rtu":
            assert s["current"] > 0.05
        else:
            assert math.isnan(s["current"])  # the URCap serves no current
        r.move(0.06)
        s = r.until(lambda s: abs(s["width"] - 0.06) <= COUNT)
        assert not s["object_detected"]


def test_a_major_fault_stops_the_fingers_raises_and_resets(bench, runner):
    regs = bench.regs
    with lifecycle(bench.make()) as g:
        r = runner(g)
        r.closing(4.0, below=0.08)
        regs.inject_fault(0x0E)
        with pytest.raises(RobotiqFault) as ei:
            r.until(lambda s: False, timeout=5.0)
        e = ei.value
        assert e.code == 0x0E and e.fault_class == "major"
        assert "overcurrent" in str(e) and "0x0E" in str(e) and bench.where in str(e) and "reset_fault()" in str(e)
        assert regs.rGTO == 0  # the driver stopped it too
        assert g.commander.holding
        stopped = regs.position
        time.sleep(0.2)
        assert regs.position == pytest.approx(stopped)
        with pytest.raises(RobotiqFault):  # still faulted: every cycle says so
            g.cycle()
        assert g.reset_fault() is True
        assert regs.activated and regs.fault == 0
        s = r.settle(0.1)
        assert s["fault"] == 0 and s["width"] == pytest.approx(stopped, abs=COUNT)
        r.move(0.07)
        r.until(lambda s: abs(s["width"] - 0.07) <= COUNT)


def test_a_minor_fault_is_published_and_logged_not_raised(bench, runner, caplog):
    with lifecycle(bench.make()) as g:
        r = runner(g)
        bench.regs.inject_fault(0x08)
        with caplog.at_level(logging.WARNING, logger="rio_robotiq"):
            s = r.settle(0.1)
        assert s["fault"] == 0x08
        assert "maximum operating temperature" in caplog.text
        r.move(0.05)
        r.until(lambda s: abs(s["width"] - 0.05) <= COUNT)  # it keeps working
        bench.regs.inject_fault(0)
        assert r.settle(0.05)["fault"] == 0


def test_an_activation_that_never_ends_names_the_gripper(bench):
    bench.regs.activation_s = 60.0
    node = bench.make(activation_timeout_s=0.3)
    with pytest.raises(ActivationError, match="did not finish activating") as ei:
        node.open()
    assert bench.where in str(ei.value) and "Robotiq 2F-85" in str(ei.value)
    bench.regs.activation_s = 0.05  # the port was released: a second try opens it again
    with lifecycle(bench.make()):
        assert bench.regs.activated


def test_disable_stops_and_enable_holds_without_moving(bench, runner):
    regs = bench.regs
    with lifecycle(bench.make()) as g:
        r = runner(g)
        r.closing(3.0, below=0.07)
        g.disable()
        assert regs.rGTO == 0 and regs.activated  # stopped, still activated
        stopped = regs.position
        time.sleep(0.2)
        assert regs.position == pytest.approx(stopped)
        g.enable()
        s = r.settle(0.2)
        assert regs.rGTO == 1 and s["width"] == pytest.approx(stopped, abs=COUNT)
    assert regs.rGTO == 0 and regs.activated  # closing disables; it does not deactivate


def test_rtu_reads_input_registers_and_writes_multiple(robotiq_rtu, runner):
    with lifecycle(RobotiqGripper(port=robotiq_rtu.port)) as g:
        r = runner(g)
        r.move(0.04)
        r.until(lambda s: abs(s["width"] - 0.04) <= COUNT)
    assert set(robotiq_rtu.device.requests) == {4, 16}  # function 4 reads, function 16 writes


def test_rtu_on_a_dead_line_names_port_and_slave(robotiq_rtu):
    robotiq_rtu.silent = True
    with pytest.raises(CommunicationError) as ei:
        RobotiqGripper(port=robotiq_rtu.port, timeout_s=0.05).open()
    assert robotiq_rtu.port in str(ei.value) and "slave id 9" in str(ei.value) and "RS-485 wiring" in str(ei.value)


def test_rtu_another_slave_id_is_not_answered(robotiq_rtu):
    with pytest.raises(CommunicationError, match="slave id 3"):
        RobotiqGripper(port=robotiq_rtu.port, slave_id=3, timeout_s=0.05).open()


def test_urcap_speaks_the_documented_lines(urcap, runner):
    with lifecycle(RobotiqUrcapGripper(ip=urcap.host, port=urcap.port, force=235.0)) as g:
        r = runner(g)
        r.move(0.0425)
        r.until(lambda s: abs(s["width"] - 0.0425) <= COUNT)
    lines = urcap.lines
    assert "SET ACT 0 ATR 0" in lines and "SET ACT 1" in lines and "GET STA" in lines
    assert "SET POS 128 SPE 255 FOR 255 GTO 1" in lines
    assert {"GET POS", "GET OBJ", "GET FLT"} <= set(lines)
    assert lines[-1] == "SET GTO 0"  # closing disables


def test_urcap_dropped_connection_is_a_named_error(urcap):
    with lifecycle(RobotiqUrcapGripper(ip=urcap.host, port=urcap.port, timeout_s=0.5)) as g:
        urcap.drop_clients()
        with pytest.raises(CommunicationError, match=f"URCap {urcap.host}:{urcap.port}"):
            for _ in range(5):
                g.cycle()


def test_emulator_ports_start_private_emulators(runner):
    for node in (RobotiqGripper(port="emulator", model="2f140"), RobotiqUrcapGripper(ip="emulator", model="hande")):
        with lifecycle(node) as g:
            r = runner(g)
            w = 0.5 * g.config.max_width
            r.move(w)
            r.until(lambda s, w=w: abs(s["width"] - w) <= 0.001)
        assert node._emulator is None and node.device is None  # stopped with the node
