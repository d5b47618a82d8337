"""The gripper contract: a parallel gripper commanded by finger opening in meters (0 = closed).

A driver writes `read_width() -> {"position": m, [extra keys declared in setup()]}` and
`write_width(width, force)` (this cycle's goal, and the grip force in N where the hardware takes one,
else NaN), plus `set_enabled(on)` where the hardware can switch. The kind owns the rest: targets are
clipped to `[0, max_width]`, interpolated to `t_cmd_target`, move at most `max_step_m` per cycle and are
held by the watchdog, through the same `JointCommander` the arms use.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Any

import numpy as np
from pydantic import Field

from .. import clock
from ..control.commander import JointCommander
from ..errors import InvalidRequest
from ..node import Node, NodeConfig, client_side, remote
from .joints import t_target

log = logging.getLogger("rio.interfaces")


class GripperNode(Node):
    class Config(NodeConfig):
        rate_hz: float = Field(50.0, gt=0, description="loop rate (Hz)")
        max_width: float = Field(0.08, gt=0, description="full opening (m)")
        max_step_m: float = Field(0.01, gt=0, description="largest opening change per cycle (m)")
        watchdog_s: float = Field(0.5, gt=0, description="hold when no command came for this long mid-move (s)")
        force: float | None = Field(None, ge=0, description="grip force (N) where the hardware takes one; "
                                                            "default: the hardware's")
        enable_on_open: bool = Field(True, description="enable when the node starts")
        disable_on_close: bool = Field(True, description="disable when the node stops (a held object may drop)")

    # -- driver hooks -------------------------------------------------------------------------------
    def read_width(self) -> Mapping[str, Any]:
        raise NotImplementedError(f"{type(self).__name__} must define read_width()")

    def write_width(self, width: float, force: float) -> None:
        raise NotImplementedError(f"{type(self).__name__} must define write_width()")

    def set_enabled(self, enabled: bool) -> None:
        """Torque / activation on or off. Default: nothing to switch."""

    # -- contract -----------------------------------------------------------------------------------
    def setup(self) -> None:
        self.width = float(self.config.max_width)
        self.example_data = {"position": 0.0, "max_width": self.width, "enabled": False, "holding": True}
        self.example_request = {"position": 0.0, "t_cmd_target": 0.0, "force": 0.0}
        self.enabled = False
        self.force = np.nan if self.config.force is None else float(self.config.force)
        self.commander: JointCommander | None = None

    def opened(self) -> None:
        now = float(self.read_width()["position"])
        self.commander = JointCommander([0.0], [self.width], self.config.max_step_m, self.config.watchdog_s,
                                        start=[now])
        if self.config.enable_on_open:
            self.enable()

    def closing(self) -> None:
        if self.enabled and self.config.disable_on_close:
            try:
                self.set_enabled(False)
            except Exception as e:
                log.warning("node '%s': disabling failed while closing: %s", self.name, e)
            self.enabled = False

    def read_state(self) -> dict[str, Any]:
        sample = dict(self.read_width())
        sample["max_width"] = self.width
        sample["enabled"] = self.enabled
        sample["holding"] = True
        if self.enabled:
            assert self.commander is not None  # made in opened(), before enable()
            self.write_width(float(self.commander.step(clock.now())[0]), self.force)
            sample["holding"] = self.commander.holding
        return sample

    def handle_request(self, request: dict[str, Any]) -> None:
        if not self.enabled:
            raise InvalidRequest(self.name, "position", "the gripper is disabled (call enable() first)")
        force = float(request["force"])
        if force > 0:
            self.force = force
        assert self.commander is not None  # made in opened(), before enable()
        self.commander.command([float(request["position"])], float(request["t_cmd_target"]), clock.now())

    # -- remote API ---------------------------------------------------------------------------------
    @remote
    def enable(self) -> bool:
        """Switch on, holding the present opening."""
        self.set_enabled(True)
        assert self.commander is not None  # made in opened()
        self.commander.reset([float(self.read_width()["position"])], clock.now())
        self.enabled = True
        return True

    @remote
    def disable(self) -> bool:
        assert self.commander is not None  # made in opened()
        self.commander.hold(clock.now())
        self.set_enabled(False)
        self.enabled = False
        return False

    # -- client side --------------------------------------------------------------------------------
    @client_side
    def max_width(self) -> float:
        return self.width

    @client_side
    def move(self, position: float, t_cmd_target: float | None = None, force: float | None = None) -> None:
        """Opening target in meters (clipped to [0, max_width]); `force` in N where the hardware takes one."""
        self.send_request(position=float(position), t_cmd_target=t_target(t_cmd_target),
                          force=0.0 if force is None else float(force))


GripperConfig = GripperNode.Config
