"""How a teleop loop finds the arms of any embodiment and turns an end-effector target into that
arm's part of the action.

An embodiment's action layout names its parts: `joint_pos` or `eef_pose` per arm (prefixed
`arm1_`/`arm2_` when there are two), then `gripper` and `hand` parts with the same prefix, and on a mobile
manipulator `base_twist`, which the controller fills. Arms are
matched to their station roles in order (`arm`, `arm2`). For an `eef_pose` part the target goes out
as is (the driver does Cartesian control); for `joint_pos` the loop solves IK itself with the arm's
`robot_description()` (shared IK, `rio.kinematics`), warm-started from the previous solution.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rio.embodiments.arm_group import ACTION_SPACES
from rio.embodiments.mobile import BASE_TWIST
from rio.errors import RioError
from rio.loop.tracking import arm_labels, arm_roles

#: A target further than this from what IK reaches is pulled back, so it never runs off.
MAX_TARGET_LEAD_M = 0.03


@dataclass
class ArmBinding:
    role: str
    prefix: str
    space: str
    client: Any
    gripper: Any = None
    max_width: float = 0.0
    hand_label: str | None = None
    ik: Any = None
    target: np.ndarray = field(default_factory=lambda: np.zeros(7))
    q_target: np.ndarray | None = None
    start_pose: np.ndarray = field(default_factory=lambda: np.zeros(7))
    gripper_cmd: float = 0.0
    #: this arm's dexterous hand joints, when a controller drives them (else the hand holds still)
    hand_cmd: np.ndarray | None = None

    @property
    def arm_label(self) -> str:
        return f"{self.prefix}{self.space}"

    @property
    def hand_role(self) -> str:
        return "hand" + self.role[len("arm"):]

    def reset_target(self) -> None:
        s = self.client.get_state()
        self.target = np.asarray(s["eef_pose"], dtype=np.float64).copy()
        if not np.isfinite(self.target).all():
            raise RioError(f"arm '{self.role}' publishes no end-effector pose (NaN): end-effector teleop needs "
                           "a driver that measures it or offers robot_description() (docs/drivers.md)")
        self.start_pose = self.target.copy()
        self.q_target = np.asarray(s["joint_pos"], dtype=np.float64).copy()
        if self.gripper is not None:
            self.gripper_cmd = float(self.gripper.get_state()["width"])

    def arm_command(self) -> np.ndarray:
        """This arm's action part for the current target (IK for joint-space embodiments)."""
        if self.space == "eef_pose":
            return self.target.copy()
        res = self.ik.solve(self.target, self.q_target, max_iters=10)
        self.q_target = res.q
        if res.pos_err > MAX_TARGET_LEAD_M:  # unreachable: keep the target at the arm's reach
            fk = self.ik.fk(res.q)
            self.target = np.concatenate([fk[:3], self.target[3:]])
        return res.q.copy()


def _ik_for(role: str, client: Any) -> Any:
    from rio.kinematics import solver_from_description

    desc = client.robot_description()
    if not desc:
        raise RioError(f"arm '{role}' takes joint targets and its driver offers no robot_description() for IK; "
                       "if it has Cartesian control, set [embodiment] action_space = \"eef_pose\"")
    dof = len(desc.get("joints") or [])
    # fewer than 6 joints cannot follow every orientation: keep position first
    return solver_from_description(desc, orientation_cost=1.0 if dof >= 6 else 0.1, damping=1e-4)


def bind_arms(robot: Any) -> list[ArmBinding]:
    """ArmBindings for an embodiment (`env.robot`), or a RioError saying why it cannot be teleoperated."""
    layout = robot.action_parts()
    arm_parts = [(label, label[: -len(s)], s) for label, s in arm_labels(robot)]
    roles = arm_roles(robot)
    if not arm_parts or len(arm_parts) != len(roles):
        raise RioError(f"end-effector teleop drives arms; embodiment '{robot.name}' has action parts "
                       f"{robot.describe_action()} (a humanoid needs a retargeting teleop)")
    out = []
    for (_label, prefix, space), role in zip(arm_parts, roles, strict=True):
        suffix = role[len("arm"):]
        b = ArmBinding(role=role, prefix=prefix, space=space, client=robot.clients[role])
        g = f"gripper{suffix}"
        if f"{prefix}gripper" in dict(layout) and g in robot.clients:
            b.gripper = robot.clients[g]
            b.max_width = float(b.gripper.max_width())
        if f"{prefix}hand" in dict(layout):
            b.hand_label = f"{prefix}hand"
        if space == "joint_pos":
            b.ik = _ik_for(role, b.client)
        out.append(b)
    known = {f"{b.prefix}{x}" for b in out for x in (*ACTION_SPACES, "gripper", "hand")} | {BASE_TWIST}
    unknown = [label for label, _ in layout if label not in known]
    if unknown:
        raise RioError(f"teleop does not know how to fill action parts {unknown} of '{robot.name}'")
    return out


def build_action(robot: Any, arms: list[ArmBinding], base_twist: Any = None) -> np.ndarray:
    """The embodiment's action from the arms' targets; a mobile base's part is `base_twist` (zero: stand
    still, when not given)."""
    parts: dict[str, Any] = {}
    if BASE_TWIST in dict(robot.action_parts()):
        parts[BASE_TWIST] = np.zeros(3) if base_twist is None else base_twist
    for b in arms:
        parts[b.arm_label] = b.arm_command()
        if b.gripper is not None:
            parts[f"{b.prefix}gripper"] = [b.gripper_cmd]
        if b.hand_label is not None and b.hand_cmd is not None:
            parts[b.hand_label] = b.hand_cmd
        elif b.hand_label is not None:  # a hand nobody drives holds still
            parts[b.hand_label] = robot.clients[b.hand_role].get_state()["joint_pos"]
    return robot.build_action(**parts)
