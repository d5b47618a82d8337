"""`sim.g1`, `sim.t1` and `sim.g1_hand`: the humanoids of a sim world (the Unitree G1, the Booster T1) behind
the standard `HumanoidNode` contract, and the G1's Dex3-1 hands behind `HandNode`'s.

The world is their hardware, as for `sim.arm`: each cycle a node reads its joints from the world bus and
writes the commander's goal for the next tick; the world's servos (joint PD at the physics rate, see
`rio_sim.humanoid_models`) track it, with the gains the node's config gives them (kp 0 while the node is
disabled). The humanoid's IMU is its root body: its orientation and body-frame angular velocity (constant
on a stand). Their `robot_description()`s are the models `rio teleop` retargets onto: the body for IK on
both wrists (`rio.kinematics.MultiFrameIK`; the legs are not on the wrists' chains, so they stay put) and
each Dex3-1 on its own for hand tracking (`rio.kinematics.HandRetargeter`).

One driver class serves every humanoid: `SimHumanoid` reads what differs (joints, gains, home, frames,
asset) from its `robot` module; `SimG1` and `SimT1` only name theirs.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field, field_validator

from rio import clock
from rio.interfaces import HandNode, HumanoidNode

from . import g1, t1
from .attached import Attached
from .indices import joint_indices

Gains = tuple[float, float]


class _Joints(Attached):
    """What bodies and hands share: joints of the world's humanoid (by name), their servo gains, limits."""

    def gains(self) -> list[Gains]:
        raise NotImplementedError

    def attach_joints(self) -> None:
        self.attach_world()
        self.idx = joint_indices(self.model, self.prefix, self.joint_list)
        self._kp, self._kd = np.array(self.gains(), dtype=np.float64).reshape(-1, 2).T
        self.set_enabled(False)

    def set_enabled(self, enabled: bool) -> None:
        """Off is Unitree's damping mode: kp 0, each joint a damper (on a stand the gravity feed-forward
        still carries the limbs). On: the servos hold where the joints are until the next goal."""
        if enabled:
            self.bus.command(self.idx.act, self.read_joints()["joint_pos"], clock.now())
        self.bus.set_gains(self.idx.act, self._kp if enabled else np.zeros_like(self._kp), self._kd)

    def hardware_limits(self) -> tuple[np.ndarray, np.ndarray]:
        ranges = np.array([self.model.joint(f"{self.prefix}/{n}").range for n in self.joint_list])
        return ranges[:, 0], ranges[:, 1]

    def read_joints(self) -> dict[str, Any]:
        s = self.world_state()
        return {"joint_pos": s["qpos"][self.idx.qpos], "joint_vel": s["qvel"][self.idx.dof]}

    def write_joints(self, joint_pos: np.ndarray) -> None:
        self.bus.command(self.idx.act, joint_pos, clock.now() + 1.0 / self.rate_hz)

    def close(self) -> None:
        self.detach_world()


def _gains_help(robot: ModuleType) -> str:
    groups = {k: v for k, v in robot.GAINS.items() if k in {robot.group(n) for n in robot.JOINTS}}
    return (f"servo [kp (N m/rad), kd (N m s/rad)] per joint group or joint name (a joint's own overrides its "
            f"group's), over the defaults {groups}")


class SimHumanoid(_Joints, HumanoidNode):
    """A humanoid of the world; `robot` (a `rio_sim.humanoid_models` module) says which."""

    robot: ClassVar[ModuleType] = g1

    class Config(HumanoidNode.Config):
        robot: ClassVar[ModuleType] = g1
        world: str = Field("sim", description="the sim.world the humanoid lives in")
        humanoid: str = Field("g1", description="which humanoid of the scene (its name prefix)")
        rate_hz: float = Field(100.0, gt=0, description="loop rate (Hz); the servos run at the physics rate")
        max_step_rad: float = Field(0.05, gt=0, description="largest joint goal change per cycle (rad)")
        gains: dict[str, tuple[float, float]] = Field(default_factory=dict, description=_gains_help(g1))

        @field_validator("gains")
        @classmethod
        def _known_and_positive(cls, v: dict) -> dict:
            """Group names (legs, arms, ...) or joint names (a trained checkpoint's per-joint gains)."""
            robot = cls.robot
            groups = sorted({robot.group(n) for n in robot.JOINTS})
            unknown = [k for k in v if k not in groups and k not in robot.JOINTS]
            if unknown:
                raise ValueError(f"gains: unknown key(s) {unknown}: write a joint group ({', '.join(groups)}) "
                                 f"or one of the {robot.__name__.rsplit('.', 1)[-1].upper()}'s joint names "
                                 f"({', '.join(robot.JOINTS)})")
            bad = [k for k, (kp, kd) in v.items() if kp < 0 or kd < 0]
            if bad:
                raise ValueError(f"gains: kp and kd must be >= 0 ({', '.join(bad)})")
            return v

    def setup(self) -> None:
        self.world, self.prefix = self.config.world, self.config.humanoid
        super().setup()

    def default_joint_names(self) -> list[str]:
        return list(self.robot.JOINTS)

    def default_home(self) -> list[float]:
        home = dict(zip(self.robot.JOINTS, self.robot.home(), strict=True))
        return [home.get(n, 0.0) for n in self.joint_list]

    def gains(self) -> list[Gains]:
        """Per joint: its own entry in the config's gains, else its group's there, else the default."""
        given = self.config.gains
        table = {**self.robot.GAINS, **given}
        return [tuple(given[n]) if n in given else table[self.robot.group(n)] for n in self.joint_list]

    def open(self) -> None:
        self.attach_joints()
        try:
            free = self.model.joint(f"{self.prefix}/{self.robot.FREE_JOINT}")
            self._free: tuple[int, int] | None = (int(free.qposadr[0]), int(free.dofadr[0]))
        except KeyError:  # on its stand: the root never turns
            import mujoco

            self._free = None
            data = mujoco.MjData(self.model)
            mujoco.mj_kinematics(self.model, data)
            self._quat = data.body(f"{self.prefix}/{self.robot.BASE}").xquat.copy()

    def read_joints(self) -> dict[str, Any]:
        s = self.world_state()
        out = {"joint_pos": s["qpos"][self.idx.qpos], "joint_vel": s["qvel"][self.idx.dof]}
        if self._free is None:
            out.update(base_quat=self._quat.copy(), base_ang_vel=np.zeros(3))
        else:
            q, v = self._free
            out.update(base_quat=s["qpos"][q + 3:q + 7].copy(), base_ang_vel=s["qvel"][v + 3:v + 6].copy())
        return out

    def robot_description(self) -> dict[str, Any]:
        """The body without hands (the G1's hands are their nodes' models), the hands' tool sites as IK
        frames, and what else the robot's IK wants (`IK`)."""
        return {"format": "mjcf", "xml": self.robot.asset_text(), "joints": list(self.joint_list),
                "frames": dict(self.robot.FRAMES), "frame_type": "site", "home": self.default_home(),
                **self.robot.IK}


class SimG1(SimHumanoid):
    """The Unitree G1 (29 DoF)."""


class SimT1(SimHumanoid):
    """The Booster T1 (23 DoF, joints in Booster's JointIndex order)."""

    robot = t1

    class Config(SimHumanoid.Config):
        robot: ClassVar[ModuleType] = t1
        humanoid: str = Field("t1", description="which humanoid of the scene (its name prefix)")
        gains: dict[str, tuple[float, float]] = Field(default_factory=dict, description=_gains_help(t1))


class SimG1Hand(_Joints, HandNode):
    class Config(HandNode.Config):
        side: Literal["left", "right"] = Field("right", description="which Dex3-1")
        world: str = Field("sim", description="the sim.world the G1 lives in")
        humanoid: str = Field("g1", description="which humanoid of the scene (its name prefix)")
        rate_hz: float = Field(100.0, gt=0, description="loop rate (Hz); the servos run at the physics rate")
        max_step_rad: float = Field(0.1, gt=0, description="largest joint goal change per cycle (rad)")
        gains: tuple[float, float] = Field(g1.GAINS["hands"], description="servo [kp (N m/rad), kd (N m s/rad)]")

    def setup(self) -> None:
        self.world, self.prefix, self.side = self.config.world, self.config.humanoid, self.config.side
        super().setup()

    def default_joint_names(self) -> list[str]:
        return list(g1.HAND_JOINTS[self.side])

    def gains(self) -> list[Gains]:
        return [tuple(self.config.gains)] * self.dof

    def open(self) -> None:
        try:
            self.attach_joints()
        except KeyError:
            scene = self.bus.scene if self.bus is not None else "?"
            self.detach_world()
            raise KeyError(f"scene '{scene}' has no Dex3-1 hands on '{self.prefix}'") from None

    def robot_description(self) -> dict[str, Any]:
        """The Dex3-1 alone, its palm site in RIO's palm frame and its finger keypoints as sites."""
        return {"format": "mjcf", "xml": g1.hand_xml(self.side), "joints": list(self.joint_list),
                "keypoints": g1.keypoints(self.side), "palm": f"{self.side}_palm", "side": self.side}
