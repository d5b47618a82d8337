"""What every commandable kind (joint devices, grippers) shares: one commander between commands and the
hardware, enable/disable around the driver's `set_enabled`, and disabling when the node stops.

A kind says what its commander drives (`make_commander()`, after `open()`) and how to measure it now
(`measured()`); the rest is here, once: a disabled device refuses commands (they would otherwise be
replayed on enable), `enable()` holds the measured state so nothing moves until the next command, and
`closing()` disables (torque off) even after an error, logging rather than raising so `close()` still
releases the device.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np
from pydantic import Field

from rio import clock
from rio.control.commander import JointCommander
from rio.errors import InvalidRequest
from rio.runtime.node import Node, NodeConfig, remote

log = logging.getLogger("rio.interfaces")


class CommandedNode(Node):
    class Config(NodeConfig):
        watchdog_s: float = Field(0.5, gt=0, description="hold when a stream of commands stops for this long "
                                                         "while its move is under way (s)")
        enable_on_open: bool = Field(True, description="enable (torque on, holding the present state) at start")
        disable_on_close: bool = Field(True, description="disable (torque off) when the node stops; a robot "
                                                         "without brakes sags, a held object may drop")

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
        """`enabled` and `holding` (no fresh command is being followed) on top of a sample."""
        sample["enabled"] = self.enabled
        sample["holding"] = (not self.enabled) or self.commander.holding
        return sample

    def command(self, field: str, target: Any, t_cmd_target: float) -> None:
        if not self.enabled:
            raise InvalidRequest(self.name, field, "the device is disabled (call enable() first)")
        self.commander.command(target, t_cmd_target, clock.now())

    # -- remote API ---------------------------------------------------------------------------------
    @remote
    def enable(self) -> bool:
        """Torque on, holding the present state: nothing moves until the next command."""
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
