"""The plugin as a user meets it: registered drivers with their presets, config checked against the
model, the packaged station running under `rio teleop`'s loop, and no serial or Modbus library imported
until a gripper is opened."""

from __future__ import annotations

import subprocess
import sys

import pytest
from pydantic import ValidationError
from rio_robotiq.dh.driver import DhGripper
from rio_robotiq.robotiq.driver import RobotiqGripper, RobotiqUrcapGripper

from rio.plugins import Registry
from rio.station.load import load_station

DRIVERS = {"robotiq.2f85": {"model": "2f85"}, "robotiq.2f140": {"model": "2f140"},
           "robotiq.hande": {"model": "hande"}, "robotiq.urcap": {}, "dh.ag95": {"model": "ag95"},
           "dh.ag105": {"model": "ag105"}}


def test_drivers_station_and_requirements_are_registered():
    reg = Registry()
    assert not [p for p in reg.problems if "robotiq" in str(p.plugin)], reg.problems
    drivers = {s.name: s for s in reg.specs("rio_drivers") if s.plugin == "rio-robotiq"}
    assert {n: s.preset for n, s in drivers.items()} == DRIVERS
    assert all(s.kind == "gripper" for s in drivers.values())
    assert {s.load() for s in drivers.values()} == {RobotiqGripper, RobotiqUrcapGripper, DhGripper}
    assert [s.name for s in reg.specs("rio_stations") if s.plugin == "rio-robotiq"] == ["robotiq-emulator"]
    from rio_robotiq.plugin import rio_requirements

    assert {r.module for r in rio_requirements()} == {"minimalmodbus", "serial"}


@pytest.mark.parametrize("name, fields, width", [
    ("robotiq.2f85", {"port": "/dev/ttyUSB0"}, 0.085),
    ("robotiq.2f140", {"port": "/dev/ttyUSB0"}, 0.140),
    ("robotiq.hande", {"port": "/dev/ttyUSB0", "max_width": 0.04}, 0.04),
    ("robotiq.urcap", {"ip": "10.0.0.2", "model": "2f140"}, 0.140),
    ("dh.ag95", {"port": "/dev/ttyUSB0"}, 0.095),
    ("dh.ag105", {"port": "/dev/ttyUSB0"}, 0.145),
])
def test_max_width_defaults_to_the_models_stroke(name, fields, width):
    spec = Registry().find("rio_drivers", name, "driver")
    assert spec.validate(fields).max_width == pytest.approx(width)


def test_config_is_checked_against_the_model():
    with pytest.raises(ValidationError, match="wider than the Robotiq Hand-E opens"):
        RobotiqGripper(port="x", model="hande", max_width=0.06)
    with pytest.raises(ValidationError, match="outside the Robotiq 2F-85's range"):
        RobotiqGripper(port="x", speed=0.3)
    with pytest.raises(ValidationError, match="open_count"):
        RobotiqGripper(port="x", open_count=200, closed_count=100)
    with pytest.raises(ValidationError, match="wider than the DH-Robotics AG-95"):
        DhGripper(port="x", max_width=0.1)
    with pytest.raises(ValueError, match="fixes it to '2f85'"):
        Registry().find("rio_drivers", "robotiq.2f85", "driver").validate({"port": "x", "model": "hande"})
    assert RobotiqUrcapGripper(host="h").config.port == 63352
    assert RobotiqGripper(port="x").config.slave_id == 9 and DhGripper(port="x").config.slave_id == 1


def test_the_extra_state_keys_are_declared():
    assert {"object_detected", "fault", "current"} <= set(RobotiqGripper(port="x").example_data)
    assert {"object_detected", "fault", "current"} <= set(RobotiqUrcapGripper(host="h").example_data)
    assert {"object_detected", "object_dropped"} <= set(DhGripper(port="x").example_data)


def test_listing_imports_no_serial_library():
    code = ("import sys; from rio.plugins import Registry; r = Registry(); "
            "[s.config_model() for s in r.specs('rio_drivers')]; "
            "import rio_robotiq.robotiq.driver, rio_robotiq.dh.driver, rio_robotiq.plugin; "
            "print('minimalmodbus' in sys.modules, 'serial' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "False False", out.stderr


def test_the_packaged_station_validates_and_teleoperates():
    from rio.workflows.teleop import run_teleop

    st = load_station("robotiq-emulator")
    assert st.components["gripper"].driver == "robotiq.2f85" and st.components["gripper"].config.port == "emulator"
    # down 2 cm with the gripper open, then close it; the scripted device ends the run when done
    script = {"script": "moves", "moves": [[0, 0, -0.02, 1.0, 0.5], [0, 0, 0, 0.0, 1.5]]}
    summary = run_teleop("robotiq-emulator", "scripted", device_config=script, duration=20, log=None)
    assert summary.reason == "the device finished"
    assert summary.arms[0].gripper == pytest.approx(0.0, abs=0.005)  # measured opening (m): closed
