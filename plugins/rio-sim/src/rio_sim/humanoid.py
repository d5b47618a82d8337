"""`sim.g1` and `sim.g1_hand`: the Unitree G1 of a sim world behind the standard `HumanoidNode` and
`HandNode` contracts.

The world is their hardware, as for `sim.arm`: each cycle a node reads its joints from the world bus and
writes the commander's goal for the next tick; the world's servos (joint PD at the physics rate, see
`rio_sim.g1`) track it, with the gains the node's config gives them (kp 0 while the node is disabled).
The humanoid's IMU is the pelvis: its orientation and body-frame angular velocity (constant on a stand).
Their `robot_description()`s are the models `rio teleop` retargets onto: the body for IK on both wrists
(`rio.kinematics.MultiFrameIK`; the legs are not on the wrists' chains, so they stay put) and each Dex3-1
on its own for hand tracking (`rio.kinematics.HandRetargeter`).
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field, field_validator
from rio import clock
from rio.interfaces import HandNode, HumanoidNode

from . import g1
from .attached import Attached
from .indices import joint_indices

Gains = tuple[float, float]


class _G1Joints(Attached):
    """What the body and the hands share: joints of the world's G1 (by name), their servo gains, limits."""

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


class SimG1(_G1Joints, HumanoidNode):
    class Config(HumanoidNode.Config):
        world: str = Field("sim", description="the sim.world the G1 lives in")
        humanoid: str = Field("g1", description="which humanoid of the scene (its name prefix)")
        rate_hz: float = Field(100.0, gt=0, description="loop rate (Hz); the servos run at the physics rate")
        max_step_rad: float = Field(0.05, gt=0, description="largest joint goal change per cycle (rad)")
        gains: dict[Literal["legs", "ankles", "waist", "arms", "wrists"], tuple[float, float]] = Field(
            default_factory=dict, description="servo [kp (N m/rad), kd (N m s/rad)] per joint group, over the "
                                              f"defaults {({k: v for k, v in g1.GAINS.items() if k != 'hands'})}")

        @field_validator("gains")
        @classmethod
        def _positive(cls, v: dict) -> dict:
            if any(kp < 0 or kd < 0 for kp, kd in v.values()):
                raise ValueError("gains: kp and kd must be >= 0")
            return v

    def setup(self) -> None:
        self.world, self.prefix = self.config.world, self.config.humanoid
        super().setup()

    def default_joint_names(self) -> list[str]:
        return list(g1.JOINTS)

    def default_home(self) -> list[float]:
        home = dict(zip(g1.JOINTS, g1.home(), strict=True))
        return [home.get(n, 0.0) for n in self.joint_list]

    def gains(self) -> list[Gains]:
        table = {**g1.GAINS, **self.config.gains}
        return [table[g1.group(n)] for n in self.joint_list]

    def open(self) -> None:
        self.attach_joints()
        try:
            free = self.model.joint(f"{self.prefix}/floating_base_joint")
            self._free: tuple[int, int] | None = (int(free.qposadr[0]), int(free.dofadr[0]))
        except KeyError:  # on its stand: the pelvis never turns
            import mujoco

            self._free = None
            data = mujoco.MjData(self.model)
            mujoco.mj_kinematics(self.model, data)
            self._quat = data.body(f"{self.prefix}/pelvis").xquat.copy()

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
        """The body without its hands (the hands are their nodes' models), wrist sites as IK frames."""
        return {"format": "mjcf", "xml": g1.asset_text(), "joints": list(self.joint_list),
                "frames": dict(g1.FRAMES), "frame_type": "site", "home": self.default_home()}


class SimG1Hand(_G1Joints, HandNode):
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
