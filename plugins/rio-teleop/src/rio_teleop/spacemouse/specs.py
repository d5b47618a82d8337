"""What `teleop.spacemouse` registers (merged into rio_teleop.plugin's hooks). Specs only: nothing here
imports pyspacemouse."""

from __future__ import annotations

from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec


def drivers() -> list[Spec]:
    return [Spec("teleop.spacemouse", "teleop", "rio_teleop.spacemouse.driver:SpaceMouseTeleop",
                 "3Dconnexion SpaceMouse (Compact, Wireless, Pro, Enterprise) over HID: 6-DoF tool twist, "
                 "buttons for gripper, mode and episode keys")]


def requirements() -> list[Requirement]:
    return [Requirement("pyspacemouse", "pip install pyspacemouse", "teleop.spacemouse (3Dconnexion HID devices)",
                        check="rio_teleop.spacemouse.doctor:hid_problem")]
