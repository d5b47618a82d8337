"""Robotiq's fault status (gFLT) codes with the manual's meaning and class, so an error can say what
happened instead of a number, and the driver can tell a transient condition from one that stops the
gripper.

Classes (2F-85/2F-140 and Hand-E manuals, "Fault status"): *priority* faults (solid blue LED) are
commands sent too early; *minor* faults (solid red LED) are conditions the gripper reports and keeps
running through; *major* faults (LED blinking red/blue) stop the gripper until a reset, a rising edge
of the activation bit rACT.
"""

from __future__ import annotations

PRIORITY, MINOR, MAJOR = "priority", "minor", "major"

#: gFLT -> (class, meaning)
ROBOTIQ_FAULTS: dict[int, tuple[str, str]] = {
    0x05: (PRIORITY, "action delayed: the activation (re-activation) must complete before the action"),
    0x07: (PRIORITY, "the activation bit must be set before the action"),
    0x08: (MINOR, "maximum operating temperature exceeded (>= 85 C internally); let it cool below 80 C"),
    0x09: (MINOR, "no communication for at least 1 second"),
    0x0A: (MAJOR, "under minimum operating voltage"),
    0x0B: (MAJOR, "automatic release in progress"),
    0x0C: (MAJOR, "internal fault; contact Robotiq support"),
    0x0D: (MAJOR, "activation fault: check that nothing interferes with the fingers"),
    0x0E: (MAJOR, "overcurrent triggered"),
    0x0F: (MAJOR, "automatic release completed"),
}


def fault_class(code: int) -> str | None:
    """PRIORITY, MINOR, MAJOR, or None for no fault. An undocumented non-zero code counts as major:
    an unknown condition is not one to keep moving through."""
    if code == 0:
        return None
    return ROBOTIQ_FAULTS.get(code, (MAJOR, ""))[0]


def fault_meaning(code: int) -> str:
    if code == 0:
        return "no fault"
    return ROBOTIQ_FAULTS.get(code, ("", f"undocumented fault code 0x{code:02X}"))[1]


def is_major(code: int) -> bool:
    return fault_class(code) == MAJOR
