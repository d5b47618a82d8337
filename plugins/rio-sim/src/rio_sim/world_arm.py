"""`WorldArm`: one arm of a running rio-sim world, for code in another process.

The one way for a hardware emulator (an emulated servo bus, an emulated arm controller) to be "an arm
of a running rio-sim world": attach to the world's bus by name, find the arm's joints and fingers
in the world's scene, read their positions and send timed targets to their position actuators. The
world node interpolates each target in physics time, exactly as for the `sim.arm` and `sim.gripper`
nodes, so an emulator driven by a real driver moves the simulated arm, cameras included.

    arm = WorldArm.attach("sim", "arm")        # waits for the world to come up
    q = arm.joint_pos()                         # rad, in the robot's `arm_joints` order
    arm.command_joints(q + 0.1, clock.now() + 0.5)
    arm.command_width(0.04, clock.now() + 0.2)  # fingers' opening, m
    arm.close()

A target string such as a driver's `port = "sim:left@w"` names the arm and the world; see
`parse_sim_target`.
"""

from __future__ import annotations

import numpy as np

from .bus import WorldBus
from .indices import ArmIndices, arm_indices
from .robots import RobotModel, get_robot


def parse_sim_target(text: str) -> tuple[str, str] | None:
    """'sim' -> ('arm', 'sim'); 'sim:left' -> ('left', 'sim'); 'sim:left@w' -> ('left', 'w');
    'sim:@w' -> ('arm', 'w'); anything else -> None. Returns (arm, world)."""
    if text != "sim" and not text.startswith("sim:"):
        return None
    rest = text[4:] if text.startswith("sim:") else ""
    arm, _, world = rest.partition("@")
    return arm or "arm", world or "sim"


class WorldArm:
    """An arm (and its fingers) of a running sim world. Make one with `WorldArm.attach`."""

    def __init__(self, bus: WorldBus, world: str, arm: str, robot: RobotModel, model, idx: ArmIndices):
        self.bus: WorldBus | None = bus
        self.world, self.arm, self.robot, self.model, self.idx = world, arm, robot, model, idx
        self.scene: str = bus.scene

    @classmethod
    def attach(cls, world: str = "sim", arm: str = "arm", timeout: float = 60.0) -> WorldArm:
        """Wait (up to `timeout` s) for the world `world`, then find its arm `arm` (the scene's name
        prefix: arm, left, right). Raises RioError if no world comes up, KeyError if the scene has no
        such arm."""
        from .scenes import build_model, get_scene

        bus = WorldBus.attach(world, timeout=timeout)
        try:
            model = build_model(bus.scene)
            if (model.nq, model.nv, model.nu) != (bus.nq, bus.nv, bus.nu):
                raise RuntimeError(f"scene '{bus.scene}' compiled here differs from the world's "
                                   "(different rio-sim versions in one station?)")
            robot = get_robot(get_scene(bus.scene).arm(arm).robot)
            idx = arm_indices(model, arm, robot)
        except Exception:
            bus.close()
            raise
        return cls(bus, world, arm, robot, model, idx)

    # -- state ----------------------------------------------------------------------------------
    def _state(self) -> dict:
        if self.bus is None:
            raise RuntimeError("this WorldArm is closed")
        self.bus.check_alive()
        return self.bus.read_state()  # a fresh copy: safe to call from several threads

    def joint_pos(self) -> np.ndarray:
        """The arm's joint positions (rad), in `robot.arm_joints` order."""
        return self._state()["qpos"][self.idx.qpos]

    def joint_vel(self) -> np.ndarray:
        """The arm's joint velocities (rad/s)."""
        return self._state()["qvel"][self.idx.dof]

    def finger_width(self) -> float:
        """The gripper's opening (m): the sum of the finger slides (0.0 for a robot without fingers)."""
        return float(np.sum(self._state()["qpos"][self.idx.finger_qpos]))

    @property
    def max_width(self) -> float:
        return float(self.robot.max_width)

    # -- commands -------------------------------------------------------------------------------
    def command_joints(self, q, t_target: float, joints=None) -> None:
        """Move the arm's joints to `q` (rad), reached at `t_target` (a `rio.clock.now()` time).
        `joints` (indices into `robot.arm_joints`) commands only those, `q` then one target each;
        the others keep their targets."""
        act = self.idx.act if joints is None else self.idx.act[np.atleast_1d(np.asarray(joints, dtype=int))]
        q = np.asarray(q, dtype=np.float64).reshape(-1)
        if q.shape != act.shape:
            raise ValueError(f"{self.robot.name}: {len(act)} joints to command, got {len(q)} targets")
        self.check_alive()
        self.bus.command(act, q, float(t_target))

    def command_width(self, width: float, t_target: float) -> None:
        """Open the fingers to `width` (m, their sum), split evenly between them, at `t_target`."""
        n = len(self.idx.finger_act)
        if n == 0:
            return
        self.check_alive()
        self.bus.command(self.idx.finger_act, np.full(n, float(width) / n), float(t_target))

    # -- life ------------------------------------------------------------------------------------
    def check_alive(self) -> None:
        """Raise RioError if the world has stopped (its node closed or its process died)."""
        if self.bus is None:
            raise RuntimeError("this WorldArm is closed")
        self.bus.check_alive()

    def close(self) -> None:
        if self.bus is not None:
            self.bus.close()
            self.bus = None

    def __enter__(self) -> WorldArm:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
