"""Faults a device reports without dying: the one way a commanded node holds, names and clears them.

An industrial controller (xArm, UR, Franka, Kinova) stops the arm by itself on a collision, a joint
limit or an emergency stop, and stays connected. Ending the node there would end the recording or the
policy run; carrying on would replay old goals the moment the fault clears. So a driver mixes in
`FaultHolding` ahead of its kind and calls `on_fault(Fault(...))` when the hardware reports one:

- the node stays alive and disables itself (the commander is not stepped, nothing is replayed);
- samples carry `fault_code` (0 when none; declare it in `example_data` with `FAULT_KEYS`);
- requests are refused naming the fault and how to recover (`InvalidRequest`);
- `clear_faults()` (remote) runs the driver's `clear_device_faults()`, then enables holding where the
  device is; `enable()` refuses while the hardware still reports a fault (`check_device_fault()`);
- `fault_info()` (remote) asks the hardware now.

A dropped link (a cable, a controller reboot) is the other way a device stops answering without the
node ending: the driver calls `on_lost()` (held, disabled, samples say `connected = False`, requests
refused) and retries its connection, and calls `on_restored()` each cycle the link is up, which enables
the node again holding where the device is if it was enabled when the link dropped. `link_up()` is the
driver's hook saying whether it is connected.

Vendors name their faults in their own tables (`Fault.tag` carries their code as they print it:
"C31", "0x0E", "PROTECTIVE_STOP").
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

from rio.errors import InvalidRequest
from rio.runtime.node import remote

log = logging.getLogger("rio.interfaces")

#: Keys every sample of a fault-holding node carries (merge into `example_data` in `setup()`).
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


class FaultHolding:
    """Mixed in ahead of a commanded kind (`class Arm(FaultHolding, ArmNode)`)."""

    name: str
    enabled: bool
    fault: Fault | None = None
    _enable_when_restored = False
    #: What the log says the device is ("xArm at 192.168.1.185"); set it in setup() or open().
    device_label: str = "the device"

    # -- driver hooks -----------------------------------------------------------------------------------
    def device_fault(self) -> Fault | None:
        """The hardware's fault now (asks it), or None. Default: the last one reported."""
        return self.fault

    def clear_device_faults(self) -> None:
        """Clear the fault on the hardware (raise naming what still blocks, e.g. a pressed e-stop)."""

    def link_up(self) -> bool:
        """Whether the link to the device is up (a driver with a connection that can drop says so)."""
        return True

    # -- shared -----------------------------------------------------------------------------------------
    def on_fault(self, fault: Fault) -> None:
        """The hardware reported `fault` (it stopped the device itself): hold, disabled, until cleared."""
        if self.fault != fault:
            log.error("node '%s': %s stopped: %s", self.name, self.device_label, fault)
        self.fault = fault
        self.enabled = False

    def fault_status(self) -> dict[str, Any]:
        """The `FAULT_KEYS` of a sample."""
        return {"fault_code": self.fault.code if self.fault else 0, "connected": self.link_up()}

    def on_lost(self) -> None:
        """The link dropped (the driver keeps retrying it): hold, disabled, until `on_restored()`."""
        if self.enabled:
            log.error("node '%s': lost %s; holding, reconnecting", self.name, self.device_label)
            self.enabled = False
            self._enable_when_restored = True

    def on_restored(self) -> None:
        """The link is up (call it every cycle it is: nodes sharing one connection see it come back at
        different times). After a drop: enable again, holding where the device is now, if the node was
        enabled when it dropped; a fault the device reports now is held instead, for `clear_faults()`."""
        if not self._enable_when_restored:
            return
        self._enable_when_restored = False
        fault = self.device_fault()
        if fault is not None:
            self.on_fault(fault)
            return
        log.warning("node '%s': %s is back; holding where it is", self.name, self.device_label)
        try:
            self.enable()  # type: ignore[attr-defined]  # CommandedNode.enable
        except InvalidRequest as e:
            # the link dropped again (or a fault appeared) between the driver's check and enabling: this is
            # a sample read, never a request, so it holds and says so; a dropped link re-enables next time
            self._enable_when_restored = not self.link_up()
            log.warning("node '%s': not enabled again yet: %s", self.name, e.problem)

    def check_ready(self) -> None:
        if self.fault is not None:
            raise InvalidRequest(self.name, None, f"stopped by a fault: {self.fault}")
        if not self.link_up():
            raise InvalidRequest(self.name, None, f"the link to {self.device_label} is down (reconnecting); "
                                 "nothing was sent")

    def check_device_fault(self) -> None:
        """Before enabling: the hardware's fault, if it still has one, must be cleared first (named)."""
        self.fault = self.device_fault()
        self.check_ready()

    def handle_request(self, request: dict[str, Any]) -> None:
        self.check_ready()
        super().handle_request(request)  # type: ignore[misc]  # the kind's

    @remote
    def clear_faults(self) -> str:
        """Clear the device's fault, then enable holding where it is."""
        if not self.link_up():
            raise InvalidRequest(self.name, None, f"the link to {self.device_label} is down (reconnecting): "
                                 "nothing to clear yet")
        self.clear_device_faults()
        self.fault = None
        self.enable()  # type: ignore[attr-defined]  # CommandedNode.enable
        return "cleared"

    @remote
    def fault_info(self) -> dict[str, Any] | None:
        """The device's current fault, asked now (None when there is none)."""
        f = self.device_fault()
        return None if f is None else f.as_dict()
