"""Humanoid: `humanoid` (whole body, joint space) with optional `hand` (left) and `hand2` (right).

Action (and `proprio`): body joint targets (rad), then left hand joints, then right hand joints.
"""

from __future__ import annotations

import numpy as np

from rio.embodiments.base import Embodiment
from rio.schema import HumanoidObs


class Humanoid(Embodiment):
    name = "humanoid"
    required_roles = frozenset({"humanoid"})
    optional_roles = frozenset({"hand", "hand2"})

    def setup(self) -> None:
        self.hands = [r for r in ("hand", "hand2") if r in self.clients]
        self.dofs = {r: int(self.clients[r].num_joints()) for r in ("humanoid", *self.hands)}

    def action_parts(self) -> list[tuple[str, int]]:
        return [("joint_pos", self.dofs["humanoid"])] + [(r, self.dofs[r]) for r in self.hands]

    def _joints(self, role: str) -> list[str]:
        n = self.dofs[role]
        named = self.joint_names(role, n)
        if role == "humanoid":
            return named or [f"joint_pos.{i}" for i in range(n)]
        return [f"{role}.{j}" for j in (named or [str(i) for i in range(n)])]

    def action_names(self) -> list[str]:
        return self.named_or_numbered([n for r in ("humanoid", *self.hands) for n in self._joints(r)])

    def observation_names(self) -> dict[str, list[str]]:
        body = self._joints("humanoid")
        out = {"proprio": self.action_names(), "joint_pos": body, "joint_vel": body}
        for r, field in (("hand", "hand1_joints"), ("hand2", "hand2_joints")):
            if r in self.hands:
                out[field] = self._joints(r)
        return out

    def observe(self) -> HumanoidObs:
        s = self._state("humanoid")
        hands = {r: np.asarray(self._state(r)["joint_pos"]) for r in self.hands}
        q = np.asarray(s["joint_pos"], dtype=np.float64)
        return HumanoidObs(
            proprio=np.concatenate([q, *hands.values()]), joint_pos=q, joint_vel=np.asarray(s["joint_vel"]),
            base_quat=np.asarray(s["base_quat"]), base_ang_vel=np.asarray(s["base_ang_vel"]),
            hand1_joints=hands.get("hand"), hand2_joints=hands.get("hand2"),
        )

    def apply(self, parts: dict[str, np.ndarray], t_cmd_target: float) -> None:
        self.send("humanoid", "move_joints", parts["joint_pos"], t_cmd_target)
        for r in self.hands:
            self.send(r, "move_joints", parts[r], t_cmd_target)
