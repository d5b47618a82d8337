"""One arm with its optional gripper and hand: the building block of SingleArm and Bimanual."""

from __future__ import annotations

from typing import Any

import numpy as np

ACTION_SPACES = ("joint_pos", "eef_pose")
#: The elements of an `eef_pose`: position (m), then the unit quaternion w, x, y, z.
EEF_NAMES = ("x", "y", "z", "qw", "qx", "qy", "qz")


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

    def names(self) -> dict[str, list[str]]:
        """Element names of this group's action parts and observation fields: the arm's joints as its
        driver names them (`shoulder_pan`; numbered `joint_pos.0` when it names none), the pose's
        `x` ... `qz`, `gripper`, the hand's joints (`hand.<joint>`), each prefixed like the action labels
        (`arm1_shoulder_pan` in a Bimanual)."""
        p, space = self.prefix, self.action_space
        joints = self.emb.joint_names(self.arm, self.arm_dof) or [f"{space}.{i}" for i in range(self.arm_dof)]
        joints = [f"{p}{j}" for j in joints]
        eef = [f"{p}{e}" for e in EEF_NAMES]
        out = {"action": list(joints if space == "joint_pos" else eef), "joints": joints, "eef": eef}
        if self.gripper:
            out["action"].append(f"{p}gripper")
        if self.hand:
            hand = self.emb.joint_names(self.hand, self.hand_dof) or [str(i) for i in range(self.hand_dof)]
            out["hand"] = [f"{p}hand.{j}" for j in hand]
            out["action"] += out["hand"]
        return out

    def read(self) -> dict[str, Any]:
        """proprio part (in action space order) and the schema fields of this group."""
        s = self.emb._state(self.arm)
        parts = [np.asarray(s[self.action_space], dtype=np.float64)]
        out: dict[str, Any] = {"eef": np.asarray(s["eef_pose"]), "joints": np.asarray(s["joint_pos"])}
        out["gripper_width"] = None
        if self.gripper:
            out["gripper_width"] = float(self.emb._state(self.gripper)["width"])
            parts.append(np.array([out["gripper_width"]]))
        out["hand_joints"] = None
        if self.hand:
            out["hand_joints"] = np.asarray(self.emb._state(self.hand)["joint_pos"])
            parts.append(out["hand_joints"])
        out["proprio"] = np.concatenate(parts)
        return out

    def apply(self, parts: dict[str, np.ndarray], t: float) -> None:
        p = self.prefix
        send = self.emb.send
        if self.action_space == "joint_pos":
            send(self.arm, "move_joints", parts[f"{p}joint_pos"], t)
        else:
            send(self.arm, "move_eef", parts[f"{p}eef_pose"], t)
        if self.gripper:
            send(self.gripper, "move", float(parts[f"{p}gripper"][0]), t)
        if self.hand:
            send(self.hand, "move_joints", parts[f"{p}hand"], t)
