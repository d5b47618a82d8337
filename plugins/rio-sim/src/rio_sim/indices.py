"""Where an arm's joints, fingers and actuators live in a compiled scene (qpos / dof / actuator
indices), found by name: `<arm>/<joint>` with the joint's actuator of the same name."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .robots import RobotModel


@dataclass
class ArmIndices:
    qpos: np.ndarray      # arm joint addresses in qpos
    dof: np.ndarray       # arm joint addresses in qvel
    act: np.ndarray       # arm actuators
    finger_qpos: np.ndarray
    finger_act: np.ndarray


def arm_indices(model, arm: str, robot: RobotModel) -> ArmIndices:
    def joint(n: str):
        return model.joint(f"{arm}/{n}")

    def actuator(n: str) -> int:
        return int(model.actuator(f"{arm}/{n}").id)

    try:
        return ArmIndices(
            qpos=np.array([joint(n).qposadr[0] for n in robot.arm_joints]),
            dof=np.array([joint(n).dofadr[0] for n in robot.arm_joints]),
            act=np.array([actuator(n) for n in robot.arm_joints]),
            finger_qpos=np.array([joint(n).qposadr[0] for n in robot.finger_joints]),
            finger_act=np.array([actuator(n) for n in robot.finger_joints]),
        )
    except KeyError as e:
        raise KeyError(f"the scene has no '{arm}' arm of robot '{robot.name}' ({e})") from None


@dataclass
class JointIndices:
    qpos: np.ndarray      # joint addresses in qpos
    dof: np.ndarray       # joint addresses in qvel
    act: np.ndarray       # each joint's actuator (same name)


def joint_indices(model, prefix: str, joints) -> JointIndices:
    """Indices of `<prefix>/<joint>` and its actuator of the same name, for each of `joints`."""
    try:
        js = [model.joint(f"{prefix}/{n}") for n in joints]
        return JointIndices(qpos=np.array([j.qposadr[0] for j in js]), dof=np.array([j.dofadr[0] for j in js]),
                            act=np.array([int(model.actuator(f"{prefix}/{n}").id) for n in joints]))
    except KeyError as e:
        raise KeyError(f"the scene has no '{prefix}' with these joints ({e})") from None
