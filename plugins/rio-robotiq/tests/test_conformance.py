"""Every driver of the plugin passes the gripper conformance kit against its emulator, through its real
transport: minimalmodbus on a pseudo-terminal, the URCap client on a TCP socket. The emulator hook
starts a fresh gripper per case and yields where it is; two classes use `port = "emulator"` instead, the
path a station without hardware takes."""

from __future__ import annotations

from contextlib import contextmanager

from rio_robotiq.emulator import DhRegisters, ModbusRtuDevice, RobotiqRegisters, UrcapServer

from rio.conformance.drivers import GripperConformance


class OnRobotiqLine:
    model = "2f85"
    bad_config = {"port": "/dev/nonexistent-tty"}

    @contextmanager
    def emulator(self):
        with ModbusRtuDevice(RobotiqRegisters(self.model)) as dev:
            yield {"port": dev.port}


class TestRobotiq2F85(OnRobotiqLine, GripperConformance):
    driver = "robotiq.2f85"


class TestRobotiq2F140(OnRobotiqLine, GripperConformance):
    driver = "robotiq.2f140"
    model = "2f140"


class TestRobotiqHandEEmulated(GripperConformance):
    driver = "robotiq.hande"
    config = {"port": "emulator"}
    bad_config = {"port": "/dev/nonexistent-tty"}


class TestRobotiqUrcap(GripperConformance):
    driver = "robotiq.urcap"
    config = {"model": "2f85"}
    bad_config = {"ip": "127.0.0.1", "port": 1, "connect_timeout_s": 0.0}  # nothing listens: refused

    @contextmanager
    def emulator(self):
        with UrcapServer(RobotiqRegisters("2f85")) as srv:
            yield {"ip": srv.host, "port": srv.port}


class TestDhAg95(GripperConformance):
    driver = "dh.ag95"
    bad_config = {"port": "/dev/nonexistent-tty"}

    @contextmanager
    def emulator(self):
        with ModbusRtuDevice(DhRegisters("ag95")) as dev:
            yield {"port": dev.port}


class TestDhAg105Emulated(GripperConformance):
    driver = "dh.ag105"
    config = {"port": "emulator"}
    bad_config = {"port": "/dev/nonexistent-tty"}
