"""The base's fault reports as named faults a researcher can act on.

A Gen3 stops the arm by itself on a fault and says so two ways: the arm state (`ArmStateNotification`,
`ARMSTATE_IN_FAULT`) and, for a high-level action under way, an `ActionNotification` with `ACTION_ABORT`
and its sub-error. RIO names the fault, says how to recover, and keeps the node alive with the arm held
(as rio-ufactory does), so a recording or a policy run waits for a person instead of dying.
`clear_faults()` calls `Base.ClearFaults()` and enables again holding where the arm is.

The names come from kortex's own enums (`Common_pb2.ArmState`, `Errors_pb2.SubErrorCodes`); an
emergency stop is told apart by its sub-error name (any containing "EMERGENCY").
"""

from __future__ import annotations

from rio.errors import RioError
from rio.interfaces import Fault

RECOVER = "clear it with the node's clear_faults() (Base.ClearFaults), then it holds where the arm is"
_ESTOP = "release the emergency stop (turn the red button), then clear_faults()"


#: Numeric codes published as `fault_code` (0 = none).
IN_FAULT_CODE, ESTOP_CODE, ABORTED_CODE, MAINTENANCE_CODE, REFUSED_CODE = 1, 2, 3, 4, 6


IN_FAULT = "ARMSTATE_IN_FAULT"
MAINTENANCE = "ARMSTATE_MAINTENANCE"


def from_arm_state(state: str, detail: str = "") -> Fault | None:
    """The fault an arm state name means, or None for a state that is no fault."""
    if state == IN_FAULT:
        if "EMERGENCY" in detail.upper():
            return Fault(ESTOP_CODE, "emergency_stop", f"the emergency stop was triggered ({detail})", _ESTOP)
        what = f" ({detail})" if detail else ""
        return Fault(IN_FAULT_CODE, "in_fault", f"the base put the arm in fault{what}: a joint fault, a safety "
                     "limit or a collision", RECOVER)
    if state == MAINTENANCE:
        return Fault(MAINTENANCE_CODE, "maintenance", "the arm is in maintenance (firmware update or the web "
                     "app's maintenance page)", "finish the maintenance in Kinova's web app, then clear_faults()")
    return None


def from_action_abort(sub_error: str) -> Fault:
    """An `ACTION_ABORT` notification's sub-error name as a fault."""
    if "EMERGENCY" in sub_error.upper():
        return Fault(ESTOP_CODE, "emergency_stop", f"the emergency stop aborted the motion ({sub_error})", _ESTOP)
    return Fault(ABORTED_CODE, "action_aborted", f"the base aborted the motion ({sub_error or 'no detail'})",
                 RECOVER)


class KinovaError(RioError):
    """kortex refused or could not carry a command; names the base and the call."""

    def __init__(self, ip: str, what: str, detail: str):
        self.ip, self.what = ip, what
        super().__init__(f"Kinova base at {ip}: {what}: {detail}")


class KinovaFault(KinovaError):
    """The base is in fault: the arm is stopped and holds until the fault is cleared."""

    def __init__(self, ip: str, what: str, fault: Fault):
        self.fault = fault
        super().__init__(ip, what, str(fault))
