"""Calibration: the procedure on an emulated arm moved by a scripted hand, the JSON file in the config
directory, and a follower that then reads 0 rad in the middle pose and knows its limits."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest
from rio_so100.calibrate import Calibrator
from rio_so100.calibration import (
    MID,
    RAD_PER_STEP,
    ArmCalibration,
    calibration_path,
    load_calibration,
    save_calibration,
)
from rio_so100.emulator.hand import CalibrationHand
from rio_so100.errors import CalibrationError
from rio_so100.feetech import control_table as T
from rio_so100.feetech.bus import FeetechBus
from rio_so100.follower.driver import So100Follower
from rio_so100.models import ARM_IDS, ARM_JOINTS, GRIPPER, GRIPPER_ID

from rio.testing import lifecycle

JOINTS = {**dict(zip(ARM_JOINTS, ARM_IDS, strict=True)), GRIPPER: GRIPPER_ID}


def _calibrate(vbus, name="left") -> tuple[ArmCalibration, CalibrationHand]:
    hand = CalibrationHand(vbus, amplitude=800.0)
    with FeetechBus(vbus.port) as bus:
        cal = Calibrator(bus, JOINTS)
        cal.prepare()
        hand.hold_middle()
        offsets = cal.record_middle()
        hand.sweep(0.6)
        t_end = time.monotonic() + 0.7
        while time.monotonic() < t_end:
            cal.sample()
            time.sleep(0.005)
        return cal.finish("so100", "follower", name), hand, offsets


def test_calibration_records_middle_and_ranges(vbus, config_home):
    result, hand, offsets = _calibrate(vbus)
    for joint, sid in JOINTS.items():
        jc = result.joint(joint)
        assert offsets[joint] == round(hand.middles[sid] - MID)  # the middle pose reads mid-turn
        assert jc.zero == MID and jc.to_rad(MID) == 0.0
        assert abs(jc.range_min - (MID - 800)) <= 25 and abs(jc.range_max - (MID + 800)) <= 25
        servo = vbus.servo(sid)  # written into the servos: offsets and position limits
        assert servo.homing_offset == offsets[joint]
        assert (servo.reg(T.MIN_POSITION_LIMIT), servo.reg(T.MAX_POSITION_LIMIT)) == (jc.range_min, jc.range_max)
    path = save_calibration(result)
    assert path == config_home / "rio" / "calibration" / "so100-follower" / "left.json"
    assert json.loads(path.read_text())["joints"]["elbow_flex"]["id"] == 3
    assert load_calibration("left", "so100", "follower") == result


def test_a_joint_that_did_not_move_is_refused(vbus):
    with FeetechBus(vbus.port) as bus:
        cal = Calibrator(bus, JOINTS)
        cal.prepare()
        cal.record_middle()
        cal.sample()
        with pytest.raises(CalibrationError, match="shoulder_pan, shoulder_lift, .* barely moved"):
            cal.finish("so100", "follower", "x")


def test_follower_uses_the_calibration(make_vbus):
    calib_bus = make_vbus()
    result, hand, _ = _calibrate(calib_bus, name="arm1")
    save_calibration(result)
    # The same arm, power-cycled onto a fresh bus (EEPROM lost in the emulator): the driver writes the
    # calibration back into the servos, and the middle pose reads 0 rad.
    bus = make_vbus()
    for sid, servo in bus.servos.items():
        servo.encoder = hand.middles[sid] + (100 if sid == 2 else 0)
    with lifecycle(So100Follower(port=bus.port, calibration="arm1")) as node:
        s = node.cycle()
        assert np.allclose(s["joint_pos"], [0, 100 * RAD_PER_STEP, 0, 0, 0], atol=1e-9)
        assert bus.servo(2).homing_offset == result.joint("shoulder_lift").homing_offset
        lower, upper = node.joint_limits()
        assert np.allclose(upper, [result.joint(j).limits_rad()[1] for j in ARM_JOINTS])


def test_calibration_path_respects_xdg_and_accepts_paths(config_home, tmp_path):
    assert calibration_path("x", "so101", "leader") == config_home / "rio" / "calibration" / "so101-leader" / "x.json"
    assert calibration_path(str(tmp_path / "c.json"), "so100", "follower") == tmp_path / "c.json"
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(CalibrationError, match="bad.json is not valid"):
        load_calibration(str(tmp_path / "bad.json"), "so100", "follower")
