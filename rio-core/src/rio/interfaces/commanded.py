"""What every commandable kind (joint devices, grippers) shares: one commander between commands and the
hardware, enable/disable around the driver's `set_enabled`, and disabling when the node stops.

A kind says what its commander drives (`make_commander()`, after `open()`) and how to measure it now
(`measured()`); the rest is here, once: a disabled device refuses commands (they would otherwise be
replayed on enable), `enable()` holds the measured state so nothing moves until the next command, and
`closing()` disables (torque off) even after an error, logging rather than raising so `close()` still
releases the device.

Two parts a driver gives its node in `setup()` where its hardware has them, and that the kind then uses:
`self.faults` (`rio.interfaces.faults.FaultHolder`: faults the device reports, held until
`clear_faults()`) and `self.link` (`rio.interfaces.link.LinkSupervisor`: a connection that can drop).
With them, commands and `enable()` are refused naming the fault or the dropped link, and every sample
carries `fault_code` and `connected`.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np
from pydantic import Field

from rio import clock
from rio.control.commander import JointCommander
from rio.errors import InvalidRequest
from rio.interfaces.faults import FaultHolder
from rio.interfaces.link import LinkSupervisor
from rio.runtime.node import Node, NodeConfig, remote

log = logging.getLogger("rio.interfaces")


class CommandedNode(Node):
    class Config(NodeConfig):
        watchdog_s: float = Field(0.5, gt=0, description="hold when a stream of commands stops for this long "
                                                         "while its move is under way (s)")
        enable_on_open: bool = Field(True, description="enable (torque on, holding the present state) at start")
        disable_on_close: bool = Field(True, description="disable (torque off) when the node stops; a robot "
                                                         "without brakes sags, a held object may drop")

    #: Faults the device reports (`FaultHolder`), where the driver gives its node one in `setup()`.
    faults: FaultHolder | None = None
    #: A connection that can drop (`LinkSupervisor`), where the driver gives its node one in `setup()`.
    link: LinkSupervisor | None = None

    # -- driver hook --------------------------------------------------------------------------------
    def set_enabled(self, enabled: bool) -> None:
        """Torque / activation on or off. Default: nothing to switch."""

    # -- what each kind says ------------------------------------------------------------------------
    def make_commander(self) -> JointCommander:
        raise NotImplementedError

    def measured(self) -> np.ndarray:
        """The commanded quantity as the hardware measures it now."""
        raise NotImplementedError

    # -- shared -------------------------------------------------------------------------------------
    def setup(self) -> None:
        self.enabled = False
        self._commander: JointCommander | None = None

    @property
    def commander(self) -> JointCommander:
        if self._commander is None:
            raise RuntimeError(f"node '{self.name}' has no commander before it is opened")
        return self._commander

    def opened(self) -> None:
        self._commander = self.make_commander()
        self._commander.owner = f"node '{self.name}'"
        if self.config.enable_on_open:
            self.enable()

    def closing(self) -> None:
        if self.enabled and self.config.disable_on_close:
            try:
                self.set_enabled(False)
            except Exception as e:  # closing must go on to release the device
                log.warning("node '%s': disabling failed while closing: %s", self.name, e)
            self.enabled = False

    def status(self, sample: dict[str, Any]) -> dict[str, Any]:
        """`enabled` and `holding` (no fresh command is being followed) on top of a sample; with a fault
        holder, `fault_code` and `connected` too."""
        sample["enabled"] = self.enabled
        sample["holding"] = (not self.enabled) or self.commander.holding
        if self.faults is not None:
            sample["fault_code"] = self.faults.code
            sample["connected"] = self.link.up() if self.link is not None else True
        return sample

    def check_ready(self) -> None:
        """Raise `InvalidRequest` naming why the device takes no command now: a fault it reports, a link
        that is down."""
        if self.faults is not None:
            self.faults.check()
        if self.link is not None:
            self.link.check()

    def command(self, field: str, target: Any, t_cmd_target: float, single: bool = False) -> None:
        """Head for `target` by `t_cmd_target`; `single`: one deliberate move (`home()`), never held by the
        watchdog as the end of a stream (`JointCommander.move`)."""
        self.check_ready()
        if not self.enabled:
            raise InvalidRequest(self.name, field, "the device is disabled (call enable() first)")
        (self.commander.move if single else self.commander.command)(target, t_cmd_target, clock.now())

    # -- remote API ---------------------------------------------------------------------------------
    @remote
    def enable(self) -> bool:
        """Torque on, holding the present state: nothing moves until the next command. Refused, naming it,
        while the device reports a fault (asked now) or its link is down."""
        if self.faults is not None:
            self.faults.refresh()
        self.check_ready()
        self.set_enabled(True)
        self.commander.reset(self.measured(), clock.now())
        self.enabled = True
        return True

    @remote
    def disable(self) -> bool:
        """Torque off (a robot without brakes goes limp: support it first)."""
        self.commander.hold(clock.now())
        self.set_enabled(False)
        self.enabled = False
        return False

    @remote
    def hold(self) -> None:
        """Stop where the device is commanded to be now."""
        self.commander.hold(clock.now())

    @remote
    def clear_faults(self) -> str:
        """Clear the device's fault, then enable holding where it is."""
        if self.faults is None:
            raise InvalidRequest(self.name, None, f"{type(self).__name__} reports no faults: nothing to clear")
        if self.link is not None and not self.link.up():
            raise InvalidRequest(self.name, None, f"the link to {self.faults.device} is down (reconnecting): "
                                 "nothing to clear yet")
        self.faults.clear()
        self.enable()
        return "cleared"

    @remote
    def fault_info(self) -> dict[str, Any] | None:
        """The device's current fault, asked now (None when there is none, or it reports none)."""
        fault = self.faults.ask() if self.faults is not None else None
        return None if fault is None else fault.as_dict()

