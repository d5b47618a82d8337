"""The controller's error and warning codes as named faults a researcher can act on.

The xArm controller stops the arm on an error and reports a number (C31, C23, ...). RIO names the
fault, says what it means and how to recover, and keeps the node alive with the arm held, so the
recording or the policy run waits for a person instead of dying. The codes and meanings are the
controller's own (UFACTORY's "Controller Error Code" table); the recovery text is ours.
"""

from __future__ import annotations

from rio.errors import RioError
from rio.interfaces import Fault

RECOVER = "clear it with `rio ufactory clear-errors --ip IP` (or the node's clear_faults()), then enable"


def _fault(code: int, name: str, meaning: str, recovery: str = RECOVER) -> Fault:
    """A controller fault, tagged the way the controller prints it (C31)."""
    return Fault(code, name, meaning, recovery, tag=f"C{code}" if code > 0 else "")


def _servo(code: int) -> Fault:
    joint = code - 10
    return _fault(code, "servo_error", f"servo motor {joint} error" if joint else "servo motor error",
                 "check the joint for a mechanical block or over-temperature, power-cycle the arm with the "
                 "controller's emergency stop if clearing does not help")


_ESTOP = "release the emergency stop, then clear the error and enable"
FAULTS: dict[int, Fault] = {
    1: _fault(1, "emergency_stop", "the controller's emergency stop button is pushed in", _ESTOP),
    2: _fault(2, "emergency_stop", "the control box's emergency IO is triggered", _ESTOP),
    3: _fault(3, "emergency_stop", "the three-state switch's emergency stop is pressed", _ESTOP),
    **{c: _servo(c) for c in range(10, 18)},
    18: _fault(18, "communication", "force-torque sensor communication error"),
    19: _fault(19, "communication", "end effector communication error (tool RS-485: check the gripper cable "
                                   "and baud rate)"),
    21: _fault(21, "kinematics", "kinematic error (target unreachable or singular)"),
    22: _fault(22, "self_collision", "self-collision detected"),
    23: _fault(23, "joint_limit", "joint angle exceeds its limit",
              "clear the error, then move the joint back inside its range in manual mode or with a joint move"),
    24: _fault(24, "speed_limit", "speed exceeds the limit (lower max_step_rad or the command rate's jumps)"),
    25: _fault(25, "planning", "planning error"),
    26: _fault(26, "controller", "Linux real-time error"),
    27: _fault(27, "controller", "command reply error"),
    28: _fault(28, "communication", "end module communication error"),
    30: _fault(30, "speed_limit", "feedback speed exceeds the limit"),
    31: _fault(31, "collision", "collision caused abnormal current (the arm hit something or a payload is "
                               "heavier than configured)"),
    35: _fault(35, "safety_boundary", "the tool left the controller's safety boundary"),
    38: _fault(38, "joint_angle", "abnormal joint angle"),
    60: _fault(60, "speed_limit", "linear speed exceeded the limit in servo_j mode (targets jump too far "
                                 "per cycle)"),
}


#: Not an error code (reported as fault_code -1): the controller left servo mode under a running node
#: (set_state(4) or a mode change from another program, or an emergency stop on firmware that reports none).
STOPPED = _fault(-1, "stopped", "the controller stopped the arm (state 4) without an error code",
                "enable the arm again (`rio ufactory enable --ip IP` or the node's enable())")


def fault_of(code: int) -> Fault:
    return FAULTS.get(int(code), _fault(int(code), "controller_error", f"controller error C{code} (see the "
                                                                      "UFACTORY controller error code table)"))


WARNINGS = {11: "command cache full", 12: "command parameter error", 13: "command does not exist",
            14: "command has no solution (target unreachable)", 15: "modbus command cache full"}


class XArmError(RioError):
    """The SDK refused or could not carry a command; names the controller and the call."""

    def __init__(self, ip: str, what: str, detail: str):
        self.ip, self.what = ip, what
        super().__init__(f"xArm at {ip}: {what}: {detail}")


class XArmLost(XArmError):
    """The command socket dropped or the controller stopped answering; the link reconnects."""


class XArmFault(XArmError):
    """The controller is in an error state: the arm is stopped and holds until the fault is cleared."""

    def __init__(self, ip: str, what: str, fault: Fault):
        self.fault = fault
        super().__init__(ip, what, str(fault))
