"""IK for several frames of one model at once: a humanoid's two wrists, or two arms on one model.

Solving the frames together matters where they share joints (a waist turns both wrists): moving one
frame alone would drag the other. Frames without a target in a call hold their current pose, so
teleoperating one wrist leaves the other where it is.

Described like an arm, with named frames instead of one tool frame:

    {"format": "mjcf", "xml": <MJCF text>, "joints": [<all the node's joints, in its order>],
     "frames": {"left": <site>, "right": <site>}, "frame_type": "site", "home": [<rad>] (optional),
     "self_collision": true (optional), "collision_pairs": [[[<geom or body>...], [...]], ...] (optional),
     "orientation_cost": 1.0 (optional: how much the frames' orientation counts against their position)}

Only joints on the way from the root to some frame are solved by default, so a humanoid's legs stay
where they are; every other degree of freedom is frozen, as in `MinkSolver`.

Self-collision: the solution keeps each arm `min_distance` (1 cm) away from the rest of the body and
from the other arm (mink's `CollisionAvoidanceLimit`): a target inside the torso, or hands asked to
cross, stop the arm at the surface instead. The pairs are derived from the model (each frame's limb
against the other limbs and the rest of the robot, collision geoms only: `rio.kinematics.
self_collision` has the rules) unless `collision_pairs` names them, e.g.
`[[["left_elbow", "left_rubber_hand"], ["torso_link", "pelvis"]]]` (geom names, or body names for their
collision geoms); `"self_collision": false` turns it off. Pairs closer than `min_distance` in the home
pose are left out. `ik.collision_pairs` lists the geom pairs in use, `ik.clearance(q)` their smallest
distance. Each iteration moves no geom more than half of `detection_distance - min_distance` (2 cm),
so a target far from the wrist takes a few solves (teleop targets lead by millimetres). Cost: about
1.5 ms more per solve on the G1 (330 pairs; bench/retarget.py).
"""

from __future__ import annotations

import copy
from collections.abc import Collection, Mapping
from typing import Any

import numpy as np

from rio.control.se3 import as_pose, pose_error
from rio.kinematics.base import require
from rio.kinematics.mink_solver import frame_body, freeze_others, joint_table, joints_moving, load_mujoco_model
from rio.kinematics.self_collision import SelfCollision, default_pairs, distances, named_pairs

_POS_DONE, _ROT_DONE = 1e-5, 1e-4  # m, rad: closer than this, further iterations change nothing useful
_BACKTRACKS = 5  # shortenings of a step that self-collision rejects, before giving it up


class MultiFrameIK:
    """Joints for several frames' target poses at once, warm-started (teleop: one call per cycle)."""

    def __init__(self, description: dict[str, Any], *, frames: dict[str, str] | None = None,
                 joints: list[str] | None = None, orientation_cost: float = 1.0, posture_cost: float = 1e-2,
                 damping: float = 1e-4, solver: str = "daqp", min_distance: float = 0.01,
                 detection_distance: float = 0.05):
        mink = require("mink", "mink")
        self._mink = mink
        if str(description.get("format", "")).lower() != "mjcf":
            raise ValueError(f"multi-frame IK: format {description.get('format')!r} (only 'mjcf' is supported)")
        for key in ("xml", "joints"):
            if key not in description:
                raise ValueError(f"multi-frame IK: the description has no '{key}'")
        # its own copy: self-collision rewrites contact bits (rio.kinematics.self_collision)
        self.model = m = copy.deepcopy(load_mujoco_model(description["xml"]))
        self.joint_names = list(description["joints"])
        self._qadr, _, self.lower, self.upper = joint_table(m, self.joint_names)
        self.frames: dict[str, str] = dict(frames if frames is not None else description.get("frames") or {})
        if not self.frames:
            raise ValueError("multi-frame IK: no frames (give 'frames' in the description or as an argument)")
        self.frame_type = str(description.get("frame_type", "site"))
        bodies = {}
        for name, frame in self.frames.items():
            try:
                bodies[name] = frame_body(m, frame, self.frame_type)
            except ValueError as e:
                raise ValueError(f"multi-frame IK: frame '{name}': {e}") from None

        ids = [int(m.joint(n).id) for n in self.joint_names]
        if joints is None:
            chain = set().union(*(joints_moving(m, b) for b in bodies.values()))
            joints = [n for n, j in zip(self.joint_names, ids, strict=True) if j in chain]
        for n in joints:
            if n not in self.joint_names:
                raise ValueError(f"multi-frame IK: joint '{n}' is not one of the description's joints")
        self.solved_joints = [n for n in self.joint_names if n in set(joints)]
        self._solved = np.array([n in set(joints) for n in self.joint_names], dtype=bool)
        _, dofs, _, _ = joint_table(m, self.solved_joints)

        # a description may weigh orientation itself: arms without a wrist (a T1) cannot hold both
        self.orientation_cost = float(description.get("orientation_cost", orientation_cost))
        self.damping, self.solver = float(damping), solver
        self.configuration = mink.Configuration(m)
        self._q_ref = m.qpos0.copy()
        # lm_damping grows with the error: a far, unreachable target gets short steps and a settled
        # best effort instead of wild linearized jumps; near the goal it vanishes
        self._tasks = {name: mink.FrameTask(frame, self.frame_type, position_cost=1.0,
                                            orientation_cost=self.orientation_cost, lm_damping=0.1)
                       for name, frame in self.frames.items()}
        # The posture pulls redundant joints (a 7-joint arm's elbow) toward home rather than wherever
        # the last call left them, so the arms keep one shape over a long teleop session.
        home = self._q_ref.copy()
        if description.get("home") is not None:
            home[self._qadr] = self._as_joints(description["home"], "home")
        self._posture = mink.PostureTask(m, cost=float(posture_cost))
        self._posture.set_target(home)
        self._limits = [mink.ConfigurationLimit(m, gain=0.95)]
        self._collisions: SelfCollision | None = None
        if description.get("self_collision", True):
            self._collisions = self._self_collision(description, list(bodies.values()), home, min_distance,
                                                    detection_distance)
            if self._collisions is not None:
                self._limits.append(self._collisions)
        self._constraints = freeze_others(m, dofs) or None

    def _self_collision(self, description: Mapping[str, Any], bodies: list[int], home: np.ndarray,
                        min_distance: float, detection_distance: float) -> SelfCollision | None:
        try:
            pairs = (named_pairs(self.model, description["collision_pairs"]) if "collision_pairs" in description
                     else default_pairs(self.model, bodies))
            guard = SelfCollision(self.model, pairs, home, float(min_distance), float(detection_distance))
        except ValueError as e:
            raise ValueError(f"multi-frame IK: {e}") from None
        return guard if guard.pairs else None

    @property
    def collision_pairs(self) -> list[tuple[int, int]]:
        """The geom ids kept apart (none when self-collision is off)."""
        return list(self._collisions.pairs) if self._collisions is not None else []

    @property
    def dof(self) -> int:
        return len(self.joint_names)

    def _as_joints(self, q: Any, what: str = "joints") -> np.ndarray:
        v = np.asarray(q, dtype=np.float64).reshape(-1)
        if v.shape != (self.dof,):
            raise ValueError(f"multi-frame IK: {what} has {v.size} values, the description {self.dof} "
                             f"({self.joint_names})")
        if not np.isfinite(v).all():
            raise ValueError(f"multi-frame IK: {what} not finite: {v.tolist()}")
        return v

    def _frame(self, name: str) -> str:
        if name not in self.frames:
            raise ValueError(f"multi-frame IK: no frame '{name}' (frames: {sorted(self.frames)})")
        return self.frames[name]

    def _pose(self, name: str) -> np.ndarray:
        w = self.configuration.get_transform_frame_to_world(self.frames[name], self.frame_type).wxyz_xyz
        return np.concatenate([w[4:], w[:4]])

    def fk(self, q: Any, frame_name: str) -> np.ndarray:
        """Pose `[x, y, z, qw, qx, qy, qz]` of a named frame in the model's world frame at joints `q`
        (all the description's joints)."""
        self._frame(frame_name)
        full = self._q_ref.copy()
        full[self._qadr] = self._as_joints(q)
        self.configuration.update(full)
        return self._pose(frame_name)

    def solve(self, targets: Mapping[str, Any], q_current: Any, *, max_iters: int = 10,
              position_only: Collection[str] = frozenset()) -> np.ndarray:
        """All the description's joints bringing each targeted frame to its pose (world frame), warm-started
        at `q_current`; the frames without a target hold their current pose, the joints not solved keep
        their values, the solved ones stay within their limits. An unreachable target gets the closest
        pose the joints allow. Frames in `position_only` ignore their targets' orientation."""
        mink = self._mink
        goals = {}
        for name, target in targets.items():
            self._frame(name)
            try:
                goals[name] = as_pose(target)
            except ValueError as e:
                raise ValueError(f"multi-frame IK: target of frame '{name}': {e}") from None
            if not np.isfinite(goals[name]).all():
                raise ValueError(f"multi-frame IK: target of frame '{name}' not finite")
        for name in position_only:
            self._frame(name)
        q = self._as_joints(q_current, "q_current").copy()
        q[self._solved] = np.clip(q, self.lower, self.upper)[self._solved]
        full = self._q_ref.copy()
        full[self._qadr] = q
        cfg = self.configuration
        cfg.update(full)
        for name, task in self._tasks.items():
            goal = goals[name] if name in goals else self._pose(name)
            goals[name] = goal
            task.set_target(mink.SE3(np.concatenate([goal[3:], goal[:3]])))
            task.set_orientation_cost(0.0 if name in position_only else self.orientation_cost)
        tasks = [*self._tasks.values(), self._posture]
        for _ in range(max_iters):
            if all(self._done(name, goals[name], name in position_only) for name in self._tasks):
                break
            v = mink.solve_ik(cfg, tasks, 1.0, self.solver, damping=self.damping, limits=self._limits,
                              constraints=self._constraints)
            if not self._step(v, q):
                break
        q[self._solved] = cfg.q[self._qadr][self._solved]
        return q

    def _step(self, v: np.ndarray, q: np.ndarray) -> bool:
        """Moves the configuration along `v` (unsolved joints kept at `q`, solved ones within limits). With
        self-collision the step is shortened while it moves a geom too far or brings a pair too near
        (`SelfCollision`); False when no step would do: the configuration stays where it was."""
        cfg, guard = self.configuration, self._collisions
        before, scale = cfg.q.copy(), 1.0
        for _ in range(_BACKTRACKS):
            full = cfg.integrate(v, scale)
            full[self._qadr] = np.where(self._solved, np.clip(full[self._qadr], self.lower, self.upper), q)
            cfg.update(full)
            if guard is None:
                return True
            over = guard.overshoot(cfg.data)
            if over <= 1.0 and guard.kept_apart(cfg.data):
                return True
            cfg.update(before)
            scale *= 0.95 / over if over > 1.0 else 0.5
        return False

    def clearance(self, q: Any) -> float:
        """The smallest distance between the geoms of `collision_pairs` at joints `q` (m; negative where they
        penetrate, 1 m when there are none or all are farther)."""
        full = self._q_ref.copy()
        full[self._qadr] = self._as_joints(q)
        self.configuration.update(full)
        return float(distances(self.model, self.configuration.data, self.collision_pairs).min(initial=1.0))

    def _done(self, name: str, goal: np.ndarray, position_only: bool) -> bool:
        pe, re = pose_error(self._pose(name), goal)
        return pe < _POS_DONE and (position_only or re < _ROT_DONE)
