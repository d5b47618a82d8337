"""Errors a gripper user can act on. Each names the gripper and where it is connected (port, slave id,
host), because on a bench with several RS-485 adapters "no answer" alone does not say which one."""

from __future__ import annotations

from rio.errors import RioError

from .faults import fault_class, fault_meaning


class GripperError(RioError):
    """Base of this plugin's errors."""


class CommunicationError(GripperError):
    """The port or socket cannot be opened, or the gripper does not answer (or answers nonsense)."""


class ActivationError(GripperError):
    """Activation (Robotiq) or initialization (DH) did not complete in time."""


class GripperFault(GripperError):
    """The gripper reports a fault that stops it (Robotiq major faults, a DH gripper that lost its
    initialization). The driver has stopped the fingers; `reset_fault()` (or restarting the node)
    re-activates it."""

    def __init__(self, message: str, code: int = 0):
        self.code = code
        super().__init__(message)


class RobotiqFault(GripperFault):
    """A Robotiq fault status (gFLT), with the manual's meaning."""

    def __init__(self, label: str, where: str, code: int):
        self.label, self.where = label, where
        self.meaning = fault_meaning(code)
        self.fault_class = fault_class(code)
        super().__init__(f"{label} on {where}: {self.fault_class} fault 0x{code:02X}: {self.meaning}. The fingers are "
                         "stopped; call reset_fault() (or restart the node) to re-activate the gripper", code)
