"""`sim.base`: a sim world's mobile base (`rio_sim.scenes.BaseMount`) behind the standard base contract
(`rio.interfaces.BaseNode`).

The world's base is a planar body driven by its body twist (velocity actuators on its x, y and yaw joints),
not by simulated wheel contacts: each cycle the twist the base kind allows (speed and acceleration limits,
stop watchdog) is turned into the world frame at the measured heading and sent to those actuators. The
wheels are what an omni-wheel base of the configured geometry would turn: their speeds are the inverse
kinematics (`rio.control.omni`) of the measured body twist, their angles its integral, and the odometry
is the core's (`rio.control.odometry`) on the body twist of those wheel speeds, as on the real base, but
over simulated time: a world that cannot keep up runs slower than the wall clock (`rtf` < 1), and
wall-clock integration would then put the base further than it went. The simulated pose is published as
`true_pose` (ground truth, to judge the odometry against).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import Field

from rio import clock
from rio.control.odometry import PlanarOdometry
from rio.interfaces.base import OmniBaseNode
from rio.runtime.node import remote

from .attached import WorldAttachment
from .indices import joint_indices
from .world_base import PLANAR, to_body, to_world


class SimBase(OmniBaseNode):
    class Config(OmniBaseNode.Config):
        base: str = Field("base", description="the scene's base (its name prefix)")
        world: str = Field("sim", description="the sim.world this base lives in")

    def setup(self) -> None:
        super().setup()
        c = self.config
        self.example_data = {**self.example_data, "true_pose": np.zeros(3)}
        self.sim = WorldAttachment(c.world)

    def open(self) -> None:
        self.sim.attach()
        self.idx = joint_indices(self.sim.model, self.config.base, PLANAR)
        self.wheel_pos = np.zeros(self.n_wheels)
        self.sim_odometry = PlanarOdometry()
        self._t: float | None = None  # simulated time of the last read
        self._yaw = 0.0

    def close(self) -> None:
        self.sim.detach()

    def read_wheels(self) -> dict[str, Any]:
        s = self.sim.state()
        x, y, yaw = (float(v) for v in s["qpos"][self.idx.qpos])
        body = to_body(*(float(v) for v in s["qvel"][self.idx.dof]), yaw)  # world velocity into the base frame
        wheel_vel = self.kinematics.to_wheels(body)
        t = float(s["sim_time"])
        if self._t is not None and t > self._t:
            self.wheel_pos = self.wheel_pos + wheel_vel * (t - self._t)
        self._t, self._yaw = t, yaw
        twist = self.kinematics.to_body(wheel_vel)
        return {"wheel_pos": self.wheel_pos.copy(), "wheel_vel": wheel_vel, "body_twist": twist,
                "odom_pose": self.sim_odometry.update(twist, t),
                "true_pose": np.array([x, y, math.atan2(math.sin(yaw), math.cos(yaw))])}

    @remote
    def reset_odometry(self, pose: list[float] | None = None) -> None:
        super().reset_odometry(pose)
        self.sim_odometry.reset(self.odometry.pose)

    def write_twist(self, twist: np.ndarray) -> None:
        self.sim.bus.command(self.idx.act, to_world(twist, self._yaw), clock.now() + 1.0 / self.rate_hz)
