"""Retargeting a tracked human hand onto a dexterous robot hand, joint targets from keypoints.

The tracker's keypoints (`rio.interfaces.teleop.HAND_JOINTS`, any frame, meters) are brought into the
operator's palm frame, scaled to the robot's size, placed in the robot hand's model through its palm
site, and the robot's joints are solved (mink, position-only frame tasks) so that the robot's sites
land where the operator's joints are. Expressing both hands in one palm frame makes the result
independent of where the tracker is and how the operator holds the hand; only the fingers count.

The palm frame, one convention for human and robot hands (a robot hand's `palm` site must follow it):

- origin at the wrist;
- x from the wrist toward the middle finger's knuckle (MCP joint, `middle-finger-phalanx-proximal`);
- z out of the palm, on the palmar side (the way the palm faces), perpendicular to x and to the line
  from the pinky's knuckle to the index finger's;
- y = z x x: toward the pinky on a right hand, toward the thumb on a left hand (a left hand is the
  right one mirrored, and a right-handed frame cannot follow a mirror image).

A hand's `robot_description()`:

    {"format": "mjcf", "xml": <MJCF text>, "joints": [<the node's joint names, in its order>],
     "keypoints": {<HAND_JOINTS name>: <site name>, ...}, "palm": <site name>, "side": "right" | "left"}

`keypoints` names the human joints the robot has an equivalent of: fingertips at least; knuckles and
the joints between them make the finger's flexion unique where the robot has them.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rio.control.rotations import matrix_to_quat
from rio.kinematics.base import require
from rio.kinematics.hand_skeleton import HAND_JOINTS
from rio.kinematics.mink_solver import frame_body, freeze_others, joint_table, joints_moving, load_mujoco_model

_INDEX = {name: i for i, name in enumerate(HAND_JOINTS)}
_MIDDLE = ("middle-finger-phalanx-proximal", "middle-finger-phalanx-intermediate", "middle-finger-phalanx-distal",
           "middle-finger-tip")
_KEYS = ("format", "xml", "joints", "keypoints", "palm", "side")


def palm_axes(keypoints: Any, side: str) -> tuple[np.ndarray, np.ndarray]:
    """(origin, 3x3 rotation whose columns are the palm frame's axes) in the keypoints' frame."""
    kp = np.asarray(keypoints, dtype=np.float64)
    wrist = kp[_INDEX["wrist"]]
    x = kp[_INDEX["middle-finger-phalanx-proximal"]] - wrist
    across = kp[_INDEX["index-finger-phalanx-proximal"]] - kp[_INDEX["pinky-finger-phalanx-proximal"]]
    z = np.cross(across, x) if side == "right" else np.cross(x, across)
    nx, nz = np.linalg.norm(x), np.linalg.norm(z)
    if not (nx > 1e-6 and nz > 1e-9):
        raise ValueError("hand keypoints: degenerate palm (wrist and knuckles in a line)")
    x = x / nx
    z = z / nz  # already perpendicular to x (a cross product with it)
    return wrist, np.column_stack([x, np.cross(z, x), z])


def palm_pose(keypoints: Any, side: str = "right") -> np.ndarray:
    """The operator's palm frame `[x, y, z, qw, qx, qy, qz]` in the keypoints' frame (module docstring)."""
    origin, rot = palm_axes(keypoints, side)
    return np.concatenate([origin, matrix_to_quat(rot)])


def _check(desc: Any) -> None:
    if not isinstance(desc, dict):
        raise ValueError(f"hand description: expected a dict, got {type(desc).__name__}")
    for key in _KEYS:
        if key not in desc:
            raise ValueError(f"hand description: missing '{key}'")
    if str(desc["format"]).lower() != "mjcf":
        raise ValueError(f"hand description: format {desc['format']!r} (only 'mjcf' is supported)")
    if desc["side"] not in ("right", "left"):
        raise ValueError(f"hand description: side {desc['side']!r} (expected 'right' or 'left')")
    if not desc["keypoints"]:
        raise ValueError("hand description: 'keypoints' maps no joint")
    for name in desc["keypoints"]:
        if name not in _INDEX:
            raise ValueError(f"hand description: keypoint '{name}' is not a HAND_JOINTS name")


class HandRetargeter:
    """Joint targets for a robot hand from a tracked hand's keypoints, one call per teleop cycle.

    Each call runs a few differential-IK iterations warm-started from the previous result (or
    `q_prev`): at 50-100 Hz the hand moves little between calls, so a handful of steps track it, and
    consecutive results stay close (no jumps between equivalent solutions). Fingertips weigh more
    than the other joints (`tip_weight`, `other_weight`) because where the tips are is what grasps;
    the other joints shape the fingers. A small posture cost toward the model's reference
    configuration settles what the keypoints do not determine; kept small (1e-4) because it also
    biases what they do determine, most on short distal phalanges."""

    def __init__(self, description: dict[str, Any], *, scale: float | None = None, tip_weight: float = 1.0,
                 other_weight: float = 0.2, posture_cost: float = 1e-4, iterations: int = 10,
                 damping: float = 1e-6, solver: str = "daqp"):
        mink = require("mink", "mink")
        _check(description)
        self._mink = mink
        self.side: str = description["side"]
        self.model = m = load_mujoco_model(description["xml"])
        self.joint_names = list(description["joints"])
        self._qadr, dofs, self.lower, self.upper = joint_table(m, self.joint_names)
        self.palm = str(description["palm"])
        try:
            palm_body = frame_body(m, self.palm)
            bodies = {k: frame_body(m, s) for k, s in description["keypoints"].items()}
        except ValueError as e:
            raise ValueError(f"hand description: {e}") from None
        self.keypoints: dict[str, str] = dict(description["keypoints"])
        # Joints that would move the palm (a wrist, a floating base) stay at the reference: the targets
        # are placed through the palm's reference pose, and moving the hand is the arm's business.
        palm_joints = joints_moving(m, palm_body)
        ids = [int(m.joint(n).id) for n in self.joint_names]
        self._solved = np.array([j not in palm_joints for j in ids], dtype=bool)
        self.iterations, self.damping, self.solver = int(iterations), float(damping), solver

        self.configuration = mink.Configuration(m)
        self._q_ref = m.qpos0.copy()
        self.configuration.update(self._q_ref)
        self._palm_pos, self._palm_rot = self._site(self.palm)
        self._tasks = {}  # sites the solved joints can move; the others (knuckles on the palm) are fixed
        solved = {j for j, s in zip(ids, self._solved, strict=True) if s}
        for name, site in self.keypoints.items():
            if joints_moving(m, bodies[name]) & solved:
                weight = tip_weight if name.endswith("-tip") else other_weight
                # damping that grows with the error: short steps toward out-of-reach targets, none near the goal
                self._tasks[name] = mink.FrameTask(site, "site", position_cost=float(weight), orientation_cost=0.0,
                                                   lm_damping=1.0)
        posture = mink.PostureTask(m, cost=float(posture_cost))
        posture.set_target(self._q_ref)
        self._all_tasks = [*self._tasks.values(), posture]
        self._limits = [mink.ConfigurationLimit(m, gain=0.95)]
        self._constraints = freeze_others(m, [d for d, s in zip(dofs, self._solved, strict=True) if s]) or None
        self._fixed_scale = None if scale is None else float(scale)
        self._robot_length, self._human_chain = self._reference_length()
        self._last: np.ndarray | None = None

    @property
    def dof(self) -> int:
        return len(self.joint_names)

    def _site(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        data = self.configuration.data
        site = data.site(name)
        return site.xpos.copy(), site.xmat.reshape(3, 3).copy()

    def _reference_length(self) -> tuple[float, list[str]]:
        """The robot's wrist-to-middle-finger length at the reference configuration (meant to be the
        open, flat hand), to the middle finger's most proximal mapped joint, and the human joints whose
        chain measures the same length on the operator. Bone lengths do not change as fingers bend, so
        the scale follows the operator's hand size without a calibration step and without jitter from
        finger motion."""
        for i, name in enumerate(_MIDDLE):
            if name in self.keypoints:
                pos, _ = self._site(self.keypoints[name])
                return float(np.linalg.norm(pos - self._palm_pos)), list(_MIDDLE[:i + 1])
        return 0.0, []

    def scale_for(self, keypoints: Any) -> float:
        """Robot size over human size for these keypoints: `scale` when given, else the robot's
        wrist-to-middle-finger length over the operator's (1.0 when the robot maps no middle finger)."""
        if self._fixed_scale is not None:
            return self._fixed_scale
        if not self._human_chain:
            return 1.0
        kp = np.asarray(keypoints, dtype=np.float64)
        points = kp[[_INDEX["wrist"], *(_INDEX[n] for n in self._human_chain)]]
        human = float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
        if not human > 1e-6:
            raise ValueError("hand keypoints: degenerate hand (zero wrist-to-knuckle length)")
        return self._robot_length / human

    def _full(self, q: np.ndarray) -> np.ndarray:
        full = self._q_ref.copy()
        full[self._qadr] = np.where(self._solved, q, self._q_ref[self._qadr])
        return full

    def _as_joints(self, q: Any) -> np.ndarray:
        v = np.asarray(q, dtype=np.float64).reshape(-1)
        if v.shape != (self.dof,):
            raise ValueError(f"hand joints: expected {self.dof} values {self.joint_names}, got {v.size}")
        if not np.isfinite(v).all():
            raise ValueError("hand joints: not finite")
        return v

    def targets(self, keypoints: Any) -> dict[str, np.ndarray]:
        """Where each mapped site should be, in the robot's palm frame (scaled operator keypoints)."""
        kp = np.asarray(keypoints, dtype=np.float64)
        if kp.shape != (len(HAND_JOINTS), 3):
            raise ValueError(f"hand keypoints: expected shape ({len(HAND_JOINTS)}, 3), got {kp.shape}")
        if not np.isfinite(kp).all():
            raise ValueError("hand keypoints: not finite")
        origin, rot = palm_axes(kp, self.side)
        s = self.scale_for(kp)
        return {name: s * ((kp[_INDEX[name]] - origin) @ rot) for name in self.keypoints}

    def __call__(self, keypoints: Any, q_prev: Any = None) -> np.ndarray:
        """Joint targets (the description's joint order, within the model's limits) for these keypoints
        (`HAND_JOINTS` order, shape (25, 3)), warm-started at `q_prev` (default: the previous result)."""
        mink = self._mink
        goal = self.targets(keypoints)
        for name, task in self._tasks.items():
            world = self._palm_pos + self._palm_rot @ goal[name]
            task.set_target(mink.SE3.from_translation(world))
        if q_prev is not None:
            q = self._as_joints(q_prev)
        else:
            q = self._q_ref[self._qadr] if self._last is None else self._last
        cfg = self.configuration
        full = self._full(np.clip(q, self.lower, self.upper))  # the limits are constraints: start inside
        for _ in range(self.iterations):
            cfg.update(full)
            v = mink.solve_ik(cfg, self._all_tasks, 1.0, self.solver, damping=self.damping, limits=self._limits,
                              constraints=self._constraints)
            cfg.integrate_inplace(v, 1.0)
            full = self._full(np.clip(cfg.q[self._qadr], self.lower, self.upper))
            if float(np.max(np.abs(v))) < 1e-3:  # converged to 1 mrad (or stuck at a limit): the rest moves nothing
                break
        self._last = np.clip(full[self._qadr], self.lower, self.upper)
        return self._last.copy()

    def reset(self) -> None:
        """Forget the previous result (the next call starts from the reference configuration), for a
        hand re-acquired after tracking was lost."""
        self._last = None

    def model_keypoints(self, q: Any) -> dict[str, np.ndarray]:
        """Each mapped site's position in the robot's palm frame at joints `q` (forward kinematics)."""
        self.configuration.update(self._full(self._as_joints(q)))
        palm_pos, palm_rot = self._site(self.palm)
        return {name: (self._site(site)[0] - palm_pos) @ palm_rot for name, site in self.keypoints.items()}
