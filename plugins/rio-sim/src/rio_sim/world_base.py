"""`WorldBase`: the mobile base of a running rio-sim world, for code in another process (an emulated wheel
servo bus), as `WorldArm` is for an arm.

The world's base is a planar body driven by its body twist (velocity actuators on its x, y and yaw joints,
`rio_sim.scenes.BaseMount`), not by wheel contacts. So a wheel emulator reads the base's measured body twist
(and the simulated time, to turn wheel speeds into wheel angles over simulated time, as `sim.base` does) and
commands a body twist (what its wheels' goal speeds add up to); the frame changes are here, shared with
`sim.base`.

    base = WorldBase.attach("sim", "base")       # waits for the world to come up
    twist, t_sim = base.body_twist()              # [vx, vy, wz] in the base's frame; simulated time (s)
    base.command_twist([0.1, 0.0, 0.0], clock.now() + 0.02)
    base.close()
"""

from __future__ import annotations

import math

import numpy as np

from .bus import WorldBus
from .indices import JointIndices, joint_indices

#: The base body's joints (and velocity actuators of the same names) in the scene, under its prefix.
PLANAR = ("x", "y", "yaw")


def to_body(vx: float, vy: float, wz: float, yaw: float) -> np.ndarray:
    """A world-frame planar velocity as the base's body twist at heading `yaw`."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c * vx + s * vy, -s * vx + c * vy, wz])


def to_world(twist, yaw: float) -> np.ndarray:
    """A body twist `[vx, vy, wz]` as the world-frame velocity of the base's planar joints at heading `yaw`."""
    vx, vy, wz = (float(v) for v in twist)
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c * vx - s * vy, s * vx + c * vy, wz])


class WorldBase:
    """The base `base` (the scene's name prefix) of a running sim world. Make one with `WorldBase.attach`."""

    def __init__(self, bus: WorldBus, world: str, base: str, idx: JointIndices):
        self.bus: WorldBus | None = bus
        self.world, self.base, self.idx = world, base, idx
        self._buf: dict | None = None

    @classmethod
    def attach(cls, world: str = "sim", base: str = "base", timeout: float = 60.0) -> WorldBase:
        """Wait (up to `timeout` s) for the world `world`, then find its base `base`. Raises RioError if no world
        comes up, KeyError if the scene has no such base."""
        from .scenes import build_model

        bus = WorldBus.attach(world, timeout=timeout)
        try:
            model = build_model(bus.scene)
            if (model.nq, model.nv, model.nu) != (bus.nq, bus.nv, bus.nu):
                raise RuntimeError(f"scene '{bus.scene}' compiled here differs from the world's "
                                   "(different rio-sim versions in one station?)")
            idx = joint_indices(model, base, PLANAR)
        except Exception:
            bus.close()
            raise
        return cls(bus, world, base, idx)

    def _state(self) -> dict:
        if self.bus is None:
            raise RuntimeError("this WorldBase is closed")
        self.bus.check_alive()
        return self.bus.read_state()  # a fresh copy: safe to call from several threads

    def pose(self) -> np.ndarray:
        """`[x, y, yaw]` of the base in the world (m, rad): the ground truth."""
        x, y, yaw = (float(v) for v in self._state()["qpos"][self.idx.qpos])
        return np.array([x, y, math.atan2(math.sin(yaw), math.cos(yaw))])

    def body_twist(self) -> tuple[np.ndarray, float]:
        """(the measured body twist `[vx, vy, wz]` in the base's frame, the simulated time it is at)."""
        s = self._state()
        yaw = float(s["qpos"][self.idx.qpos][2])
        vx, vy, wz = (float(v) for v in s["qvel"][self.idx.dof])
        return to_body(vx, vy, wz, yaw), float(s["sim_time"])

    def command_twist(self, twist, t_target: float) -> None:
        """Drive the base at body twist `twist` (m/s, m/s, rad/s), reached at `t_target` (`rio.clock` time),
        turned into the world frame at the heading it has now."""
        yaw = float(self._state()["qpos"][self.idx.qpos][2])
        assert self.bus is not None
        self.bus.command(self.idx.act, to_world(twist, yaw), float(t_target))

    def close(self) -> None:
        if self.bus is not None:
            self.bus.close()
            self.bus = None

    def __enter__(self) -> WorldBase:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
