"""The controller's safety and robot modes as named faults a researcher can act on.

A UR stops itself (protective stop on a collision or a limit, emergency stop, safeguard stop from a
light curtain); RIO names the stop, says how to recover, and keeps the node alive with the arm held.
The mode numbers are the controller's (RTDE `safety_mode`, `robot_mode`); the recovery text is ours.
"""

from __future__ import annotations

from rio.errors import RioError
from rio.interfaces import Fault

_UNLOCK = ("find and remove the cause, then `rio ur unlock-protective-stop --ip IP` (or the node's "
           "clear_faults()); the controller refuses an unlock in the first 5 s")
_ESTOP = ("release the emergency stop button, then `rio ur power-on --ip IP` and `rio ur brake-release --ip IP` "
          "(or the node's clear_faults())")


def _safety(mode: int, tag: str, name: str, meaning: str, recovery: str) -> Fault:
    """A safety-mode stop (code = the mode), tagged as the controller names the mode."""
    return Fault(mode, name, meaning, recovery, tag=tag)


def _robot(mode: int, tag: str, name: str, meaning: str, recovery: str) -> Fault:
    """A robot mode the arm cannot move in (code = 100 + the mode)."""
    return Fault(100 + mode, name, meaning, recovery, tag=tag)


#: safety_mode -> fault (1 NORMAL and 2 REDUCED are not faults).
SAFETY_FAULTS = {
    3: _safety(3, "PROTECTIVE_STOP", "protective_stop", "the controller stopped the arm (a collision, a joint or "
                                                        "tool limit, a target too fast)", _UNLOCK),
    4: _safety(4, "RECOVERY", "recovery", "the arm is outside its safety limits (recovery mode)",
               "jog it back inside the limits on the teach pendant"),
    5: _safety(5, "SAFEGUARD_STOP", "safeguard_stop", "a safeguard input stopped the arm (light curtain, door "
                                                      "switch)",
               "clear the safeguard; the arm resumes when it is reset"),
    6: _safety(6, "SYSTEM_EMERGENCY_STOP", "emergency_stop", "the system emergency stop input is active", _ESTOP),
    7: _safety(7, "ROBOT_EMERGENCY_STOP", "emergency_stop", "an emergency stop button is pressed", _ESTOP),
    8: _safety(8, "VIOLATION", "violation", "a safety limit was violated (the safety system stopped the arm)",
               "check the safety configuration on the pendant, then `rio ur restart-safety --ip IP`"),
    9: _safety(9, "FAULT", "fault", "the safety system reports a fault", "read the pendant's log, then restart "
                                                                        "safety or power-cycle the controller"),
    12: _safety(12, "AUTOMATIC_MODE_SAFEGUARD_STOP", "safeguard_stop", "automatic-mode safeguard stop",
                "reset the safeguard"),
    13: _safety(13, "SYSTEM_THREE_POSITION_ENABLING_STOP", "enabling_stop",
                "three-position enabling device released", "press the enabling device"),
}
#: robot_mode -> fault (7 RUNNING is the only mode the arm moves in). Codes are 100 + the mode, apart from
#: the safety modes above.
ROBOT_MODE_FAULTS = {
    3: _robot(3, "POWER_OFF", "power_off", "the arm is powered off",
              "`rio ur power-on --ip IP` then `rio ur brake-release`"),
    4: _robot(4, "POWER_ON", "power_on", "the arm is powering on", "wait, then `rio ur brake-release --ip IP`"),
    5: _robot(5, "IDLE", "idle", "the arm is powered with its brakes on", "`rio ur brake-release --ip IP`"),
    6: _robot(6, "BACKDRIVE", "backdrive", "the arm is in backdrive mode", "leave backdrive on the pendant"),
}


def fault_of(safety_mode: int, robot_mode: int) -> Fault | None:
    """The fault a state is in, safety first; None when the arm can move."""
    if safety_mode in SAFETY_FAULTS:
        return SAFETY_FAULTS[safety_mode]
    if robot_mode != 7:
        return ROBOT_MODE_FAULTS.get(robot_mode, _robot(robot_mode, f"robot mode {robot_mode}", "not_running",
                                                        f"robot mode {robot_mode}", "power on and release brakes"))
    return None


REMOTE_HINT = ("the controller must be in Remote Control for ur-rtde to upload its control script: on the "
               "teach pendant enable Settings > System > Remote Control, then switch Local -> Remote at the top "
               "right (`rio ur status --ip IP` prints 'remote control: true' when it is)")


class URError(RioError):
    """ur-rtde could not connect or carry a command; names the controller."""

    def __init__(self, ip: str, what: str, detail: str):
        self.ip, self.what = ip, what
        super().__init__(f"UR at {ip}: {what}: {detail}")
