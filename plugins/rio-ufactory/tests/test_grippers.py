"""The tool-connector grippers through the unmodified xArm SDK against the emulator's tool port:
opening and closing to a width, an object stopping the fingers, and the tool-IO grippers."""

from __future__ import annotations

import pytest
from rio_ufactory.gripper.bio import BioGripper
from rio_ufactory.gripper.lite6 import Lite6Gripper, VacuumGripper
from rio_ufactory.gripper.robotiq import XArmRobotiq
from rio_ufactory.gripper.xarm_gripper import XArmGripper

from rio import clock
from rio.conformance.driving import Loop
from rio.testing import lifecycle


def run_until(node, pred, timeout: float = 10.0) -> dict:
    return Loop(node).run(until=pred, timeout=timeout)


# driver, its fields, the emulator's tool device, where the emulated fingers put the object for an opening
# (the BIO gripper's fingers measure the jaw distance: 71 mm when closed)
CASES = {
    "xarm": (XArmGripper, {}, "xarm", 0.0),
    "xarm_g2": (XArmGripper, {"generation": 2, "max_width": 0.084}, "xarm_g2", 0.0),
    "bio": (BioGripper, {}, "bio", 0.071),
    "robotiq": (XArmRobotiq, {}, "robotiq", 0.0),
}


@pytest.mark.parametrize("case", list(CASES))
def test_gripper_moves_to_widths_and_stops_on_an_object(make_emulator, case):
    if case == "robotiq":
        pytest.importorskip("rio_robotiq")
    cls, fields, tool, jaw = CASES[case]
    emu = make_emulator("xarm7", gripper=tool)
    with lifecycle(cls(ip=emu.host, **fields)) as grip:
        w = grip.width
        tol = 0.03 * w + 0.002  # the devices' own position units (pulses, mm, 1/255 of the stroke)
        for goal in (0.8 * w, 0.3 * w):
            grip.command("width", [goal], clock.now() + 0.3)
            s = run_until(grip, lambda s, g=goal: abs(s["width"] - g) < tol)
            assert abs(s["width"] - goal) < tol, (case, goal, s["width"])
            assert not s["object_detected"]
        grip.command("width", [w], clock.now() + 0.2)
        run_until(grip, lambda s: s["width"] > 0.95 * w - tol)
        emu.gripper.fingers.object_width = jaw + 0.5 * w
        grip.command("width", [0.0], clock.now() + 0.2)
        s = run_until(grip, lambda s: s["object_detected"])
        assert s["object_detected"], (case, s)
        assert abs(s["width"] - 0.5 * w) < tol, (case, s["width"])


def test_lite6_gripper_opens_and_closes_on_tool_io(make_emulator):
    emu = make_emulator("lite6", gripper="lite6")
    with lifecycle(Lite6Gripper(ip=emu.host)) as grip:
        grip.command("width", [0.0], clock.now() + 0.1)
        fingers = emu.gripper.fingers
        s = run_until(grip, lambda s: s["width"] == 0.0 and fingers.update() < 1e-4)
        assert s["width"] == 0.0 and fingers.goal == 0.0 and fingers.update() < 1e-4
        grip.command("width", [grip.width], clock.now() + 0.1)
        s = run_until(grip, lambda s: fingers.update() > fingers.max_width - 1e-4)
        assert s["width"] == grip.width and fingers.goal == fingers.max_width


def test_vacuum_reports_a_held_object(make_emulator):
    emu = make_emulator("lite6", gripper="lite6")
    emu.gripper.vacuum_object = True
    with lifecycle(VacuumGripper(ip=emu.host)) as cup:
        cup.command("width", [0.0], clock.now() + 0.1)  # closed = suction on
        s = run_until(cup, lambda s: s["object_detected"])
        assert s["object_detected"] and emu.gripper.suction
        cup.command("width", [cup.width], clock.now() + 0.1)
        s = run_until(cup, lambda s: not s["object_detected"])
        assert not s["object_detected"] and not emu.gripper.suction
