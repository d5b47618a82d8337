"""The mobile base contract: a planar base commanded by its body twist `[vx, vy, wz]` (m/s, m/s, rad/s;
x forward, y left, z up, in the base's own frame).

A driver writes hardware logic only:

- `default_wheel_names()` (or the station sets `wheel_names`), cheap, no hardware;
- `open()` / `close()`;
- `read_wheels() -> {"wheel_pos": (n) rad, "wheel_vel": (n) rad/s, ["body_twist": (3)], ["odom_pose": (3)],
  [extra keys declared in setup()]}`;
- `write_twist(twist)`: this cycle's body twist, already limited (a wheeled driver turns it into wheel
  speeds with its kinematics, e.g. `rio.control.omni.OmniKinematics`);
- `body_twist_of(wheel_vel)`: its forward kinematics, where `read_wheels()` reports no body twist;
- optionally `set_enabled(on)` (torque).

The kind runs one `cycle()` per tick: `read_wheels()`, `commander.step(now)`, `write_twist(goal)`. Between
commands and wheels stands one `TwistCommander` (`rio.control.twist_commander`): speed limits,
acceleration limits per cycle, and a stale-command watchdog that ramps the base to a stop when commands stop
coming (a base keeps rolling at its last speed; an arm holds still). The kind also keeps the odometry:
`odom_pose` `[x, y, theta]` integrated from the measured body twist (exact arcs, `rio.control.odometry`)
unless the driver reports its own. A disabled base refuses commands; closing stops it (a zero twist) before
torque goes off.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from pydantic import Field

from rio import clock
from rio.control.odometry import PlanarOdometry
from rio.control.twist_commander import TwistCommander
from rio.interfaces.commanded import CommandedNode
from rio.interfaces.joints import as_vector, t_target
from rio.runtime.node import client_side, remote

_NAN3 = np.full(3, np.nan)


class BaseNode(CommandedNode):
    client_state = ("wheel_list", "n_wheels")

    class Config(CommandedNode.Config):
        defaults = {"watchdog_s": Field(0.3, gt=0, description="stop the base when no command has come for this "
                                                               "long (s)")}
        rate_hz: float = Field(50.0, gt=0, description="loop rate (Hz)")
        wheel_names: list[str] | None = Field(None, min_length=1, description="wheels, in the driver's order "
                                                                              "(default: the driver's)")
        max_linear_speed: float = Field(0.3, ge=0, description="largest speed of travel, norm of vx, vy (m/s)")
        max_angular_speed: float = Field(1.5, ge=0, description="largest turning rate |wz| (rad/s)")
        max_linear_accel: float = Field(1.0, gt=0, description="largest change of the linear velocity (m/s^2)")
        max_angular_accel: float = Field(4.0, gt=0, description="largest change of the turning rate (rad/s^2)")

    # -- driver hooks -------------------------------------------------------------------------------
    def default_wheel_names(self) -> list[str]:
        raise NotImplementedError(f"{type(self).__name__} defines no default_wheel_names(): set wheel_names")

    def read_wheels(self) -> Mapping[str, Any]:
        raise NotImplementedError(f"{type(self).__name__} must define read_wheels()")

    def write_twist(self, twist: np.ndarray) -> None:
        raise NotImplementedError(f"{type(self).__name__} must define write_twist()")

    def body_twist_of(self, wheel_vel: np.ndarray) -> np.ndarray | None:
        """Forward kinematics: the body twist of these wheel speeds, or None where the driver has none
        (then `read_wheels()` must report `body_twist`, else it is NaN)."""
        return None

    def write_disabled(self) -> None:
        """What the hardware gets in a cycle while the node is disabled. Default: nothing."""

    # -- contract -----------------------------------------------------------------------------------
    def setup(self) -> None:
        super().setup()
        self.wheel_list = list(self.config.wheel_names or self.default_wheel_names())
        n = self.n_wheels = len(self.wheel_list)
        self.example_data: dict[str, Any] = {"wheel_pos": np.zeros(n), "wheel_vel": np.zeros(n),
                                             "body_twist": np.zeros(3), "odom_pose": np.zeros(3),
                                             "enabled": False, "holding": True}
        self.example_request: dict[str, Any] = {"twist": np.zeros(3), "t_cmd_target": 0.0}
        self.odometry = PlanarOdometry()

    def make_commander(self) -> TwistCommander:  # type: ignore[override]
        c = self.config
        return TwistCommander(c.max_linear_speed, c.max_angular_speed, c.max_linear_accel, c.max_angular_accel,
                              self.rate_hz, c.watchdog_s, start=self.measured())

    def measured(self) -> np.ndarray:
        return self._twist_of(dict(self.read_wheels()))

    def _twist_of(self, sample: Mapping[str, Any]) -> np.ndarray:
        if "body_twist" in sample:
            return np.asarray(sample["body_twist"], dtype=np.float64).reshape(3)
        tw = self.body_twist_of(np.asarray(sample["wheel_vel"], dtype=np.float64))
        return _NAN3.copy() if tw is None else np.asarray(tw, dtype=np.float64).reshape(3)

    def cycle(self) -> dict[str, Any]:
        """One tick at `rate_hz` (the runtime calls it): read the wheels, step the commander, write the twist
        it allows this cycle; the sample is completed after the write, so `holding` is this cycle's."""
        sample = dict(self.read_wheels())
        if self.enabled:
            self.write_twist(self.commander.step(clock.now()))
        else:
            self.write_disabled()
        return self.complete(sample)

    def read_state(self) -> dict[str, Any]:
        """The base now with the kind's keys: a read only, nothing is written (see `cycle()`)."""
        return self.complete(dict(self.read_wheels()))

    def complete(self, sample: dict[str, Any]) -> dict[str, Any]:
        """The contract's keys on top of what the driver read: the body twist (measured, else forward
        kinematics of the wheel speeds, else NaN) and the odometry (the driver's, else integrated here)."""
        sample["body_twist"] = self._twist_of(sample)
        if "odom_pose" not in sample:
            sample["odom_pose"] = self.odometry.update(sample["body_twist"], clock.now())
        return self.status(sample)

    def closing(self) -> None:
        if self.enabled:  # a base rolls on at its last speed: stop it before torque goes off
            try:
                self.write_twist(np.zeros(3))
            except Exception as e:  # noqa: BLE001 - closing must go on to release the device
                import logging

                logging.getLogger("rio.interfaces").warning("node '%s': stopping the base while closing failed: "
                                                            "%s", self.name, e)
        super().closing()

    def handle_request(self, request: dict[str, Any]) -> None:
        self.command("twist", np.asarray(request["twist"], dtype=np.float64), float(request["t_cmd_target"]))

    # -- remote API ---------------------------------------------------------------------------------
    @remote
    def stop(self) -> None:
        """Ramp to a stop now (within the acceleration limits), as the watchdog does."""
        self.commander.hold(clock.now())

    @remote
    def reset_odometry(self, pose: list[float] | None = None) -> None:
        """Restart the odometry at `pose` `[x, y, theta]` (default: the origin)."""
        self.odometry.reset((0.0, 0.0, 0.0) if pose is None else as_vector("pose", pose, 3))

    @remote
    def speed_limits(self) -> dict[str, float]:
        """The limits the commander enforces (m/s, rad/s, m/s^2, rad/s^2)."""
        c = self.config
        return {"max_linear_speed": c.max_linear_speed, "max_angular_speed": c.max_angular_speed,
                "max_linear_accel": c.max_linear_accel, "max_angular_accel": c.max_angular_accel}

    # -- client side --------------------------------------------------------------------------------
    @client_side
    def wheel_names(self) -> list[str]:
        return list(self.wheel_list)

    @client_side
    def move_twist(self, twist: Any, t_cmd_target: float | None = None) -> None:
        """Body twist `[vx, vy, wz]` (m/s, rad/s), to be reached at `t_cmd_target`; good for `watchdog_s`:
        send it again to keep driving."""
        self.send_request(twist=as_vector("twist", twist, 3), t_cmd_target=t_target(t_cmd_target))


BaseConfig = BaseNode.Config
