"""The contract shared by every joint-space device (arm, hand, humanoid): joint names and limits, a home
pose, enable/disable, and the one `JointCommander` between commands and the hardware.

A driver writes hardware logic only:

- `default_joint_names()` (or the station sets `joint_names`), cheap, no hardware;
- `open()` / `close()`;
- `read_joints() -> {"joint_pos": ..., ["joint_vel": ...], [extra keys declared in setup()]}`;
- `write_joints(q)`: send this cycle's goal (already interpolated, clipped and step-limited);
- optionally `set_enabled(on)` (torque), `hardware_limits()` (read after `open()`, e.g. from a
  calibration), `default_home()`.

The kind runs one `cycle()` per tick: `read_joints()`, `commander.step(now)`, `write_joints(goal)`, in
that order, so a driver never sees a raw command: every target is clipped to the limits (the hardware's,
narrowed by the station's `joint_limits`), moves at most `max_step_rad` per cycle, and is held by the
watchdog when commands stop coming mid-move. A disabled device refuses commands (they would otherwise be
replayed on enable) and gets `write_disabled()` instead of a goal.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from pydantic import Field

from rio import clock
from rio.control.commander import JointCommander
from rio.control.workspace import ToolBound
from rio.interfaces.commanded import CommandedNode
from rio.runtime.node import client_side, remote


def t_target(t_cmd_target: float | None) -> float:
    """A command's target time: now when not given."""
    return clock.now() if t_cmd_target is None else float(t_cmd_target)


def as_vector(name: str, value: Any, n: int) -> np.ndarray:
    v = np.asarray(value, dtype=np.float64).reshape(-1)
    if v.shape != (n,):
        raise ValueError(f"{name} must have {n} values, got shape {np.shape(value)}")
    return v


class JointNode(CommandedNode):
    client_state = ("joint_list", "dof")

    class Config(CommandedNode.Config):
        joint_names: list[str] | None = Field(None, min_length=1, description="joints this node drives, in command "
                                                                              "order (default: the driver's)")
        home: list[float] | None = Field(None, description="joint positions (rad) that home() moves to "
                                                           "(default: the driver's, else zeros)")
        rest: list[float] | None = Field(None, description="joint positions (rad) the device rests in, powered "
                                                           "off (`rio home --rest`; default: the driver's, "
                                                           "else none)")
        joint_limits: list[tuple[float, float]] | None = Field(
            None, description="[lower, upper] per joint (rad); narrows the hardware's own limits")
        max_step_rad: float = Field(0.05, gt=0, description="largest joint goal change per cycle (rad)")

    # -- driver hooks -------------------------------------------------------------------------------
    def default_joint_names(self) -> list[str]:
        raise NotImplementedError(f"{type(self).__name__} defines no default_joint_names(): set joint_names")

    def default_home(self) -> Any:
        """Home joint positions (rad), or None for zeros."""
        return None

    def default_rest(self) -> Any:
        """Rest joint positions (rad): where the device is parked or folded while off (an arm lying on its
        joint limits), or None when it has none. `rio home --rest` moves there."""
        return None

    def hardware_limits(self) -> Any:
        """(lower, upper) in rad, read after `open()`; None when the hardware reports none."""
        return None

    def read_joints(self) -> Mapping[str, Any]:
        raise NotImplementedError(f"{type(self).__name__} must define read_joints()")

    def write_joints(self, joint_pos: np.ndarray) -> None:
        raise NotImplementedError(f"{type(self).__name__} takes no joint targets")

    def write_disabled(self) -> None:
        """What the hardware gets in a cycle while the node is disabled. Default: nothing (the device holds
        or goes limp by itself); a device that obeys its last command until told otherwise sends a soft one
        here (a humanoid on its low-level topics: `rio.interfaces.damping`)."""

    # -- contract -----------------------------------------------------------------------------------
    def setup(self) -> None:
        super().setup()
        c = self.config
        self.joint_list = list(c.joint_names or self.default_joint_names())
        n = self.dof = len(self.joint_list)
        for field in ("home", "rest", "joint_limits"):
            value = getattr(c, field)
            if value is not None and len(value) != n:
                raise ValueError(f"{field} has {len(value)} entries; node '{self.name}' drives {n} joints "
                                 f"{self.joint_list}")
        self.example_data: dict[str, Any] = {"joint_pos": np.zeros(n), "joint_vel": np.zeros(n), "enabled": False,
                                             "holding": True}
        self.example_request: dict[str, Any] = {"joint_pos": np.zeros(n), "t_cmd_target": 0.0}

    def limits(self) -> tuple[np.ndarray, np.ndarray]:
        """The hardware's limits narrowed by the station's `joint_limits`; unbounded where neither says."""
        lower, upper = np.full(self.dof, -np.inf), np.full(self.dof, np.inf)
        hw = self.hardware_limits()
        if hw is not None:
            lower, upper = (np.asarray(x, dtype=np.float64).reshape(self.dof) for x in hw)
        if self.config.joint_limits is not None:
            lim = np.asarray(self.config.joint_limits, dtype=np.float64)
            lower, upper = np.maximum(lower, lim[:, 0]), np.minimum(upper, lim[:, 1])
        if np.any(lower > upper):
            raise ValueError(f"node '{self.name}': joint_limits do not overlap the hardware's limits "
                             f"(lower {lower.tolist()}, upper {upper.tolist()})")
        return lower, upper

    def tool_bound(self) -> ToolBound | None:
        """The task-space bound of joint targets (`rio.control.workspace.ToolBound`), where the kind has one (an
        arm with a model); None: joint limits and `max_step_rad` bound them."""
        return None

    def make_commander(self) -> JointCommander:
        lower, upper = self.limits()
        return JointCommander(lower, upper, self.config.max_step_rad, self.config.watchdog_s, start=self.measured(),
                              tool=self.tool_bound())

    def measured(self) -> np.ndarray:
        return np.asarray(self.read_joints()["joint_pos"], dtype=np.float64)

    def cycle(self) -> dict[str, Any]:
        """One tick at `rate_hz` (the runtime calls it): read the hardware, step the commander, write the goal
        it allows this cycle; the sample is completed after the write, so `holding` is this cycle's."""
        sample = dict(self.read_joints())
        if self.enabled:
            self.write_joints(self.commander.step(clock.now()))
        else:
            self.write_disabled()
        return self.complete(sample)

    def read_state(self) -> dict[str, Any]:
        """The joints now with the kind's keys: a read only, nothing is written (see `cycle()`)."""
        return self.complete(dict(self.read_joints()))

    def complete(self, sample: dict[str, Any]) -> dict[str, Any]:
        """The contract's keys on top of what the driver read: NaN for what it did not measure."""
        if "joint_vel" not in sample:
            sample["joint_vel"] = np.full(self.dof, np.nan)
        return self.status(sample)

    def handle_request(self, request: dict[str, Any]) -> None:
        self.command_joints(np.asarray(request["joint_pos"]), float(request["t_cmd_target"]))

    def command_joints(self, joint_pos: np.ndarray, t_cmd_target: float, single: bool = False) -> None:
        self.command("joint_pos", joint_pos, t_cmd_target, single)

    # -- remote API ---------------------------------------------------------------------------------
    @remote
    def home(self, seconds: float = 3.0) -> None:
        """Move to the home pose, arriving in `seconds` (still limited to `max_step_rad` per cycle): one
        deliberate move, run to its end even right after a control loop's stream of commands."""
        self.command_joints(np.asarray(self.home_pose()), clock.now() + float(seconds), single=True)

    @remote
    def home_pose(self) -> list[float]:
        """The station's `home`, else the driver's `default_home()`, else zeros (rad), clipped to the limits
        as the commander will."""
        home = self.config.home if self.config.home is not None else self.default_home()
        q = np.zeros(self.dof) if home is None else as_vector("home", home, self.dof)
        return np.clip(q, self.commander.lower, self.commander.upper).tolist()

    @remote
    def rest_pose(self) -> list[float] | None:
        """The station's `rest`, else the driver's `default_rest()` (rad, clipped to the limits), else None."""
        rest = self.config.rest if self.config.rest is not None else self.default_rest()
        if rest is None:
            return None
        return np.clip(as_vector("rest", rest, self.dof), self.commander.lower, self.commander.upper).tolist()

    @remote
    def move_to(self, joint_pos: list[float], seconds: float) -> None:
        """One deliberate move to `joint_pos` (rad), arriving in `seconds` (still limited to `max_step_rad`
        per cycle), run to its end whatever stream of commands came just before (`rio home`)."""
        self.command_joints(as_vector("joint_pos", joint_pos, self.dof), clock.now() + float(seconds), single=True)

    @remote
    def joint_limits(self) -> list[list[float]]:
        """[[lower...], [upper...]] in rad, as enforced (inf where unbounded)."""
        return [self.commander.lower.tolist(), self.commander.upper.tolist()]

    @client_side
    def joint_names(self) -> list[str]:
        return list(self.joint_list)

    @client_side
    def num_joints(self) -> int:
        return self.dof

    @client_side
    def move_joints(self, joint_pos: Any, t_cmd_target: float | None = None) -> None:
        """Joint target (rad), to be reached at `t_cmd_target`."""
        self.send_request(joint_pos=as_vector("joint_pos", joint_pos, self.dof), t_cmd_target=t_target(t_cmd_target))


JointConfig = JointNode.Config
