"""The gripper contract: a parallel gripper commanded by finger opening in meters (0 = closed).

A driver writes `read_width() -> {"width": m, [extra keys declared in setup()]}` and
`write_width(width, force)` (this cycle's goal, and the grip force in N where the hardware takes one,
else NaN), plus `set_enabled(on)` where the hardware can switch; the kind's `cycle()` calls them (read,
step the commander, write). The kind owns the rest: targets are
clipped to `[0, max_width]`, interpolated to `t_cmd_target`, move at most `max_step_m` per cycle and are
held by the watchdog, through the same `JointCommander` the arms use.

The opening has one name everywhere: `width` (the state and request key, `move(width)`), `gripper_width` in
an observation. Its old name, `position`, is still taken in a request for one release (`GripperRequest`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from pydantic import Field

from rio import clock
from rio.config import accept_renamed
from rio.control.commander import JointCommander
from rio.interfaces.commanded import CommandedNode
from rio.interfaces.joints import t_target
from rio.runtime.node import client_side


class GripperNode(CommandedNode):
    client_state = ("width",)

    class Config(CommandedNode.Config):
        rate_hz: float = Field(50.0, gt=0, description="loop rate (Hz)")
        max_width: float = Field(0.08, gt=0, description="full opening (m)")
        max_step_m: float = Field(0.01, gt=0, description="largest opening change per cycle (m)")
        force: float | None = Field(None, ge=0, description="grip force (N) where the hardware takes one; "
                                                            "default: the hardware's")

    # -- driver hooks -------------------------------------------------------------------------------
    def read_width(self) -> Mapping[str, Any]:
        raise NotImplementedError(f"{type(self).__name__} must define read_width()")

    def write_width(self, width: float, force: float) -> None:
        raise NotImplementedError(f"{type(self).__name__} must define write_width()")

    # -- contract -----------------------------------------------------------------------------------
    def setup(self) -> None:
        super().setup()
        self.width = float(self.config.max_width)
        self.example_data = {"width": 0.0, "max_width": self.width, "enabled": False, "holding": True}
        self.example_request = {"width": 0.0, "t_cmd_target": 0.0, "force": 0.0}
        self.force = np.nan if self.config.force is None else float(self.config.force)

    def make_commander(self) -> JointCommander:
        return JointCommander([0.0], [self.width], self.config.max_step_m, self.config.watchdog_s,
                              start=self.measured())

    def measured(self) -> np.ndarray:
        return np.array([float(self.read_width()["width"])])

    def cycle(self) -> dict[str, Any]:
        """One tick at `rate_hz` (the runtime calls it): read the opening, step the commander, write the
        opening it allows this cycle (and the grip force)."""
        sample = dict(self.read_width())
        if self.enabled:
            self.write_width(float(self.commander.step(clock.now())[0]), self.force)
        return self.complete(sample)

    def read_state(self) -> dict[str, Any]:
        """The opening now with the kind's keys: a read only, nothing is written (see `cycle()`)."""
        return self.complete(dict(self.read_width()))

    def complete(self, sample: dict[str, Any]) -> dict[str, Any]:
        sample["max_width"] = self.width
        return self.status(sample)

    def handle_request(self, request: dict[str, Any]) -> None:
        self.command("width", [float(request["width"])], float(request["t_cmd_target"]))
        if float(request["force"]) > 0:
            self.force = float(request["force"])

    # -- client side --------------------------------------------------------------------------------
    @client_side
    def max_width(self) -> float:
        return self.width

    @client_side
    def move(self, width: float, t_cmd_target: float | None = None, force: float | None = None) -> None:
        """Opening target in meters (clipped to [0, max_width]); `force` in N where the hardware takes one."""
        self.send_request(width=float(width), t_cmd_target=t_target(t_cmd_target),
                          force=0.0 if force is None else float(force))

    @client_side
    def send_request(self, request: Mapping[str, Any] | None = None, **fields: Any) -> None:
        """`Node.send_request`, taking a script's old key `position` for `width` with one notice."""
        super().send_request(accept_renamed(GripperRequest, {**(request or {}), **fields}))


class GripperRequest:
    """The gripper request's keys renamed in Core v3 (`rio.config.accept_renamed` reads `renamed`): the
    opening was `position`, now `width` like everywhere else."""

    renamed = {"position": "width"}


GripperConfig = GripperNode.Config
