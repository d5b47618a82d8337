"""Faults a device reports without dying: `FaultHolder`, the part of a commanded node that holds them.

An industrial controller (xArm, UR, Franka, Kinova) stops the arm by itself on a collision, a joint
limit or an emergency stop, and stays connected. Ending the node there would end the recording or the
policy run; carrying on would replay old goals the moment the fault clears. So a driver whose hardware
reports faults gives its node a holder in `setup()`, saying how to ask the hardware and how to clear it:

    self.faults = FaultHolder(self, f"xArm at {ip}", ask=self.conn.fault, clear=self.conn.clear_faults)

and reports each fault the hardware raises (`self.faults.report(fault)`). The commanded kind
(`rio.interfaces.commanded`) does the rest with the holder:

- the node stays alive and disables itself (the commander is not stepped, nothing is replayed);
- samples carry `fault_code` (0 when none) and `connected` (`FAULT_KEYS`; the holder declares them);
- requests are refused naming the fault and how to recover (`InvalidRequest`), and `enable()` asks the
  hardware first (`ask`) and refuses while it still reports one;
- `clear_faults()` (remote) runs `clear`, then enables holding where the device is; `fault_info()`
  (remote) asks the hardware now.

A dropped link is held the same way by a second part, `rio.interfaces.link.LinkSupervisor`.

Vendors name their faults in their own tables (`Fault.tag` carries their code as they print it:
"C31", "0x0E", "PROTECTIVE_STOP").
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from rio.errors import InvalidRequest

if TYPE_CHECKING:
    from rio.interfaces.commanded import CommandedNode

log = logging.getLogger("rio.interfaces")

#: Keys every sample of a node holding faults carries (the holder adds them to `example_data`).
FAULT_KEYS: dict[str, Any] = {"fault_code": 0, "connected": True}


@dataclass(frozen=True)
class Fault:
    """`code`: the number published as `fault_code` (non-zero); `name`: one word to match on
    ("collision"); `meaning` and `recovery`: what a person reads; `tag`: the vendor's own label."""

    code: int
    name: str
    meaning: str
    recovery: str = ""
    tag: str = ""

    def __str__(self) -> str:
        head = f"{self.tag} {self.name}" if self.tag else self.name
        return f"{head}: {self.meaning}" + (f"; {self.recovery}" if self.recovery else "")

    def as_dict(self) -> dict[str, Any]:
        return {"code": self.code, "name": self.name, "meaning": self.meaning, "recovery": self.recovery,
                "tag": self.tag}


class FaultHolder:
    """The fault a node's device reports, held until cleared (see the module docstring). `device` is what
    the log and refusals call it ("xArm at 192.168.1.185"); `ask()` returns the hardware's fault now (None
    when it has none; default: the one held), `clear()` clears it on the hardware (raise naming what
    still blocks, e.g. a pressed emergency stop; default: nothing to do); `on_report(fault)`, where the
    driver has more to do when a fault stops the node (ask the robot for its damping mode)."""

    def __init__(self, node: CommandedNode, device: str, *, ask: Callable[[], Fault | None] | None = None,
                 clear: Callable[[], None] | None = None, on_report: Callable[[Fault], None] | None = None):
        self.node, self.device = node, device
        self._ask, self._clear, self._on_report = ask, clear, on_report
        #: The fault held now, or None.
        self.fault: Fault | None = None
        node.example_data = {**(node.example_data or {}), **FAULT_KEYS}

    def report(self, fault: Fault) -> None:
        """The hardware reported `fault` (it stopped the device itself): hold, disabled, until cleared."""
        if self.fault != fault:
            log.error("node '%s': %s stopped: %s", self.node.name, self.device, fault)
        self.fault = fault
        self.node.enabled = False
        if self._on_report is not None:
            self._on_report(fault)

    def ask(self) -> Fault | None:
        """The hardware's fault now (asks it where the driver said how), else the one held."""
        return self._ask() if self._ask is not None else self.fault

    def refresh(self) -> None:
        """Hold what the hardware reports now (before enabling: a fault still there is refused, named)."""
        self.fault = self.ask()

    def check(self) -> None:
        """Raise `InvalidRequest` naming the fault while one is held."""
        if self.fault is not None:
            raise InvalidRequest(self.node.name, None, f"stopped by a fault: {self.fault}")

    def clear(self) -> None:
        """Clear the fault on the hardware, then forget it."""
        if self._clear is not None:
            self._clear()
        self.fault = None

    @property
    def code(self) -> int:
        """`fault_code` of a sample: the held fault's, 0 when none."""
        return self.fault.code if self.fault is not None else 0
