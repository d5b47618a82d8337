"""Shared fixtures: emulated grippers on their real transports (a pty for Modbus RTU, a TCP server for
the URCap), always closed, and `run`: tick a node the way the runtime does until an outcome shows.

Outcomes are polled with generous timeouts, never timed: the suite must hold on a loaded 2-core
machine."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import pytest
from rio_robotiq.emulator import DhRegisters, ModbusRtuDevice, RobotiqRegisters, UrcapServer

from rio import clock


@pytest.fixture
def robotiq_rtu():
    """A Robotiq 2F-85 (slave id 9) on an emulated RS-485 line: `.port`, `.device` (the registers)."""
    with ModbusRtuDevice(RobotiqRegisters("2f85")) as dev:
        yield dev


@pytest.fixture
def urcap():
    """A Robotiq 2F-85 behind an emulated URCap socket: `.host`, `.port`, `.registers`."""
    with UrcapServer(RobotiqRegisters("2f85")) as srv:
        yield srv


@pytest.fixture
def dh_rtu():
    """A DH AG-95 (slave id 1) on an emulated RS-485 line."""
    with ModbusRtuDevice(DhRegisters("ag95")) as dev:
        yield dev


class Runner:
    """Ticks `node.cycle()` at the node's rate (the runtime's loop, in the test's thread)."""

    def __init__(self, node: Any):
        self.node = node
        self.last: dict[str, Any] = {}

    def tick(self) -> dict[str, Any]:
        self.last = dict(self.node.cycle())
        time.sleep(1.0 / self.node.rate_hz)
        return self.last

    def until(self, pred: Callable[[dict[str, Any]], bool], timeout: float = 10.0) -> dict[str, Any]:
        t_end = time.monotonic() + timeout
        while time.monotonic() < t_end:
            if pred(self.tick()):
                return self.last
        raise AssertionError(f"not reached within {timeout} s; last sample: {self.last}")

    def move(self, width: float, force: float = 0.0, seconds: float = 0.1) -> None:
        """What the `move()` client call sends, handed to the node directly."""
        self.node.handle_request({"width": float(width), "t_cmd_target": clock.now() + seconds,
                                  "force": float(force)})

    def closing(self, seconds: float, below: float) -> dict[str, Any]:
        """Close the fingers over `seconds`; returns once they are under way (opening below `below` m)."""
        self.move(0.0, seconds=seconds)
        return self.until(lambda s: s["width"] < below)

    def settle(self, seconds: float = 0.3) -> dict[str, Any]:
        t_end = time.monotonic() + seconds
        while time.monotonic() < t_end:
            self.tick()
        return self.last


@pytest.fixture
def runner() -> Callable[[Any], Runner]:
    return Runner
