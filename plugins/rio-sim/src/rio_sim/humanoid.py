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
asset) from its `robot`'s module (`rio_sim.humanoid_models`); `sim.g1` and `sim.t1` are that class with
`robot` preset. What the body and the hands share, the joints of the world's humanoid by name, is a part
each holds (`WorldJoints`).
"""

from __future__ import annotations

from types import ModuleType
from typing import Any, Literal

import numpy as np
from pydantic import Field, model_validator

from rio import clock
from rio.interfaces import HandNode, HumanoidNode

from . import g1
from .attached import WorldAttachment
from .humanoid_models import get_humanoid
from .indices import joint_indices

Gains = tuple[float, float]


class WorldJoints:
    """Joints of the world's humanoid a node drives (`prefix`: the humanoid's name in the scene; `names`, in
    the node's order): their indices, servo gains and limits. Off is Unitree's damping mode: kp 0, each
    joint a damper (on a stand the gravity feed-forward still carries the limbs); on, the servos hold
    where the joints are until the next goal."""

    def __init__(self, sim: WorldAttachment, prefix: str, names: list[str], gains: list[Gains]):
        self.sim, self.prefix, self.names = sim, prefix, names
        self._kp, self._kd = np.array(gains, dtype=np.float64).reshape(-1, 2).T
        self.idx: Any = None

    def attach(self) -> None:
        self.sim.attach()
        self.idx = joint_indices(self.sim.model, self.prefix, self.names)
        self.enable(False)

    def enable(self, on: bool) -> None:
        assert self.sim.bus is not None
        if on:
            self.sim.bus.command(self.idx.act, self.read()["joint_pos"], clock.now())
        self.sim.bus.set_gains(self.idx.act, self._kp if on else np.zeros_like(self._kp), self._kd)

    def limits(self) -> tuple[np.ndarray, np.ndarray]:
        ranges = np.array([self.sim.model.joint(f"{self.prefix}/{n}").range for n in self.names])
        return ranges[:, 0], ranges[:, 1]

    def read(self) -> dict[str, Any]:
        s = self.sim.state()
        return {"joint_pos": s["qpos"][self.idx.qpos], "joint_vel": s["qvel"][self.idx.dof]}

    def write(self, joint_pos: np.ndarray, rate_hz: float) -> None:
        """The goal for the next tick: the world interpolates it in physics time."""
        assert self.sim.bus is not None
        self.sim.bus.command(self.idx.act, joint_pos, clock.now() + 1.0 / rate_hz)


def _gains_help() -> str:
    def groups(robot: ModuleType) -> dict[str, Gains]:
        return {k: v for k, v in robot.GAINS.items() if k in {robot.group(n) for n in robot.JOINTS}}

    return ("servo [kp (N m/rad), kd (N m s/rad)] per joint group or joint name (a joint's own overrides its "
            "group's), over the robot's defaults: " + "; ".join(f"{n} {groups(get_humanoid(n))}" for n in ("g1", "t1")))


class SimHumanoid(HumanoidNode):
    """A humanoid of the world; `robot` says which (registered as `sim.g1` and `sim.t1` with it preset)."""

    class Config(HumanoidNode.Config):
        defaults = {"rate_hz": 100.0, "max_step_rad": 0.05}  # the servos run at the physics rate
        robot: Literal["g1", "t1"] = Field("g1", description="which humanoid: g1 (Unitree G1), t1 (Booster T1)")
        world: str = Field("sim", description="the sim.world the humanoid lives in")
        humanoid: str | None = Field(None, description="which humanoid of the scene (its name prefix); default: "
                                                       "the robot's name")
        gains: dict[str, tuple[float, float]] = Field(default_factory=dict, description=_gains_help())

        @model_validator(mode="after")
        def _known_and_positive(self) -> Any:
            """Group names (legs, arms, ...) or joint names (a trained checkpoint's per-joint gains)."""
            robot = get_humanoid(self.robot)
            groups = sorted({robot.group(n) for n in robot.JOINTS})
            unknown = [k for k in self.gains if k not in groups and k not in robot.JOINTS]
            if unknown:
                raise ValueError(f"gains: unknown key(s) {unknown}: write a joint group ({', '.join(groups)}) "
                                 f"or one of the {self.robot.upper()}'s joint names ({', '.join(robot.JOINTS)})")
            bad = [k for k, (kp, kd) in self.gains.items() if kp < 0 or kd < 0]
            if bad:
                raise ValueError(f"gains: kp and kd must be >= 0 ({', '.join(bad)})")
            return self

    def setup(self) -> None:
        c = self.config
        self.robot = get_humanoid(c.robot)
        self.prefix = c.humanoid or c.robot
        super().setup()
        self.sim = WorldAttachment(c.world)
        self.joints = WorldJoints(self.sim, self.prefix, self.joint_list, self.gains())

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
        self.joints.attach()
        model = self.sim.model
        try:
            free = model.joint(f"{self.prefix}/{self.robot.FREE_JOINT}")
            self._free: tuple[int, int] | None = (int(free.qposadr[0]), int(free.dofadr[0]))
        except KeyError:  # on its stand: the root never turns
            import mujoco

            self._free = None
            data = mujoco.MjData(model)
            mujoco.mj_kinematics(model, data)
            self._quat = data.body(f"{self.prefix}/{self.robot.BASE}").xquat.copy()

    def close(self) -> None:
        self.sim.detach()

    def set_enabled(self, enabled: bool) -> None:
        self.joints.enable(enabled)

    def hardware_limits(self) -> tuple[np.ndarray, np.ndarray]:
        return self.joints.limits()

    def read_joints(self) -> dict[str, Any]:
        s = self.sim.state()
        out = {"joint_pos": s["qpos"][self.joints.idx.qpos], "joint_vel": s["qvel"][self.joints.idx.dof]}
        if self._free is None:
            out.update(base_quat=self._quat.copy(), base_ang_vel=np.zeros(3))
        else:
            q, v = self._free
            out.update(base_quat=s["qpos"][q + 3:q + 7].copy(), base_ang_vel=s["qvel"][v + 3:v + 6].copy())
        return out

    def write_joints(self, joint_pos: np.ndarray) -> None:
        self.joints.write(joint_pos, self.rate_hz)

    def robot_description(self) -> dict[str, Any]:
        """The body without hands (the G1's hands are their nodes' models), the hands' tool sites as IK
        frames, and what else the robot's IK wants (`IK`)."""
        return {"format": "mjcf", "xml": self.robot.asset_text(), "joints": list(self.joint_list),
                "frames": dict(self.robot.FRAMES), "frame_type": "site", "home": self.default_home(),
                **self.robot.IK}


class SimG1Hand(HandNode):
    class Config(HandNode.Config):
        defaults = {"rate_hz": 100.0, "max_step_rad": 0.1}  # the servos run at the physics rate
        side: Literal["left", "right"] = Field("right", description="which Dex3-1")
        world: str = Field("sim", description="the sim.world the G1 lives in")
        humanoid: str = Field("g1", description="which humanoid of the scene (its name prefix)")
        gains: tuple[float, float] = Field(g1.GAINS["hands"], description="servo [kp (N m/rad), kd (N m s/rad)]")

    def setup(self) -> None:
        self.side = self.config.side
        super().setup()
        self.sim = WorldAttachment(self.config.world)
        gains = [tuple(self.config.gains)] * self.dof
        self.joints = WorldJoints(self.sim, self.config.humanoid, self.joint_list, gains)

    def default_joint_names(self) -> list[str]:
        return list(g1.HAND_JOINTS[self.side])

    def open(self) -> None:
        try:
            self.joints.attach()
        except KeyError:
            scene = self.sim.bus.scene if self.sim.bus is not None else "?"
            self.sim.detach()
            raise KeyError(f"scene '{scene}' has no Dex3-1 hands on '{self.config.humanoid}'") from None

    def close(self) -> None:
        self.sim.detach()

    def set_enabled(self, enabled: bool) -> None:
        self.joints.enable(enabled)

    def hardware_limits(self) -> tuple[np.ndarray, np.ndarray]:
        return self.joints.limits()

    def read_joints(self) -> dict[str, Any]:
        return self.joints.read()

    def write_joints(self, joint_pos: np.ndarray) -> None:
        self.joints.write(joint_pos, self.rate_hz)

    def robot_description(self) -> dict[str, Any]:
        """The Dex3-1 alone, its palm site in RIO's palm frame and its finger keypoints as sites."""
        return {"format": "mjcf", "xml": g1.hand_xml(self.side), "joints": list(self.joint_list),
                "keypoints": g1.keypoints(self.side), "palm": f"{self.side}_palm", "side": self.side}
