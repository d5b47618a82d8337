"""What `teleop.gamepad` registers (merged into rio_teleop.plugin's hooks). Specs only: nothing here
imports evdev or pygame."""

from __future__ import annotations

import sys

from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec

_T = "rio_teleop.gamepad.driver:GamepadTeleop"


def drivers() -> list[Spec]:
    return [
        Spec("teleop.gamepad", "teleop", _T,
             "gamepad (Xbox, PlayStation, generic; evdev on Linux, pygame elsewhere): sticks, triggers and "
             "bumpers to a tool twist, buttons for gripper, mode and episode keys"),
        Spec("teleop.xbox", "teleop", _T, "Xbox controller (xpad / xpadneo): teleop.gamepad's xbox layout",
             preset={"family": "xbox"}),
        Spec("teleop.playstation", "teleop", _T,
             "PlayStation DualSense / DualShock 4: teleop.gamepad's playstation layout",
             preset={"family": "playstation"}),
    ]


def requirements() -> list[Requirement]:
    """The backend this platform uses: evdev on Linux, pygame elsewhere (as rio-teleop's dependencies)."""
    if sys.platform.startswith("linux"):
        return [Requirement("evdev", "pip install evdev", "teleop.gamepad on Linux (/dev/input event devices)",
                            check="rio_teleop.gamepad.doctor:input_problem")]
    return [Requirement("pygame", "pip install pygame", "teleop.gamepad on macOS and Windows (SDL game controllers)")]
