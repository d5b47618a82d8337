"""One arm with its optional gripper and hand: the building block of SingleArm and Bimanual."""

from __future__ import annotations

from typing import Any

import numpy as np

ACTION_SPACES = ("joint_pos", "eef_pose")


class ArmGroup:
    """Reads and commands `arm[+gripper][+hand]` roles (e.g. "arm2", "gripper2", "hand2")."""

    def __init__(self, emb: Any, arm: str, gripper: str, hand: str, action_space: str, prefix: str = ""):
        self.emb, self.arm, self.action_space, self.prefix = emb, arm, action_space, prefix
        self.gripper = gripper if gripper in emb.clients else None
        self.hand = hand if hand in emb.clients else None
        self.arm_dof = int(emb.clients[arm].num_joints())
        self.hand_dof = int(emb.clients[hand].num_joints()) if self.hand else 0

    def layout(self) -> list[tuple[str, int]]:
        p = self.prefix
        out = [(f"{p}{self.action_space}", self.arm_dof if self.action_space == "joint_pos" else 7)]
        if self.gripper:
            out.append((f"{p}gripper", 1))
        if self.hand:
            out.append((f"{p}hand", self.hand_dof))
        return out

    def read(self) -> dict[str, Any]:
        """proprio part (in action space order) and the schema fields of this group."""
        s = self.emb._state(self.arm)
        parts = [np.asarray(s[self.action_space], dtype=np.float64)]
        out: dict[str, Any] = {"eef": np.asarray(s["eef_pose"]), "joints": np.asarray(s["joint_pos"])}
        out["gripper"] = None
        if self.gripper:
            out["gripper"] = float(self.emb._state(self.gripper)["position"])
            parts.append(np.array([out["gripper"]]))
        out["hand_joints"] = None
        if self.hand:
            out["hand_joints"] = np.asarray(self.emb._state(self.hand)["joint_pos"])
            parts.append(out["hand_joints"])
        out["proprio"] = np.concatenate(parts)
        return out

    def apply(self, parts: dict[str, np.ndarray], t: float) -> None:
        p = self.prefix
        arm = self.emb.clients[self.arm]
        if self.action_space == "joint_pos":
            arm.move_joints(parts[f"{p}joint_pos"], t)
        else:
            arm.move_eef(parts[f"{p}eef_pose"], t)
        if self.gripper:
            self.emb.clients[self.gripper].move(float(parts[f"{p}gripper"][0]), t)
        if self.hand:
            self.emb.clients[self.hand].move_joints(parts[f"{p}hand"], t)
