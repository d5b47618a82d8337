"""Standard node interfaces: the state keys, request keys and client methods every driver of a kind
shares, so an embodiment (and a user's main loop) can drive any arm, gripper, camera, hand or
humanoid without knowing which vendor is behind it.

A driver subclasses one of these, passes its sizes to `__init__`, returns the documented keys from
`read_state()`, and implements the `command_*` method(s) its hardware supports. Clients call the
client-side helpers (`move_joints`, `move_eef`, `move`), which fill a complete fixed-layout request.

Units are SI everywhere: meters, radians, seconds. Poses are `[x, y, z, qw, qx, qy, qz]` (meters,
unit quaternion, scalar first) in the robot's base frame. `t_cmd_target` is a `rio.time.now()` time
at which the target should be reached (drivers interpolate towards it); None means "as soon as
possible" and is sent as the current time.

| kind     | state (`get_state()`)                                            | request / client call            |
|----------|------------------------------------------------------------------|----------------------------------|
| arm      | joint_pos (n) rad, joint_vel (n) rad/s, eef_pose (7)             | move_joints(q, t) / move_eef(pose, t) |
| gripper  | position m (finger opening), max_width m                         | move(position_m, t)              |
| hand     | joint_pos (n) rad                                                | move_joints(q, t)                |
| humanoid | joint_pos (n), joint_vel (n), base_quat (4, wxyz), base_ang_vel (3) rad/s | move_joints(q, t)       |
| camera   | rgb (H,W,3) uint8; with depth: depth (H,W) uint16, depth_scale m/unit; intrinsics (3,3) | -          |
| teleop   | twist (6: m/s, rad/s), gripper (0 closed .. 1 open), buttons (n) | -                                |

Every sample also carries `timestamp` (added by the runtime). A value a driver cannot measure (an arm
without forward kinematics has no `eef_pose`) is published as NaN, never as a made-up number.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from . import time as rtime
from .errors import InvalidRequest
from .node import Node, client_side

#: Request `mode` values of an arm.
JOINT, EEF = 0, 1

IDENTITY_POSE = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])


def _t(t_cmd_target: float | None) -> float:
    return rtime.now() if t_cmd_target is None else float(t_cmd_target)


def _vec(name: str, value: Any, n: int) -> np.ndarray:
    v = np.asarray(value, dtype=np.float64).reshape(-1)
    if v.shape != (n,):
        raise ValueError(f"{name} must have {n} values, got shape {np.shape(value)}")
    return v


class ArmNode(Node):
    """A serial arm: joint and/or Cartesian targets. Override `command_joints` and/or `command_eef`."""

    __api__ = ("get_state", "send_request", "move_joints", "move_eef", "num_joints")

    def __init__(self, dof: int, *, rate_hz: float | None = None):
        super().__init__(rate_hz=rate_hz)
        self.dof = int(dof)
        self.example_data = {"joint_pos": np.zeros(self.dof), "joint_vel": np.zeros(self.dof),
                             "eef_pose": IDENTITY_POSE.copy()}
        self.example_request = {"mode": JOINT, "joint_pos": np.zeros(self.dof),
                                "eef_pose": IDENTITY_POSE.copy(), "t_cmd_target": 0.0}

    @client_side
    def num_joints(self) -> int:
        return self.dof

    @client_side
    def move_joints(self, joint_pos: Any, t_cmd_target: float | None = None) -> None:
        """Joint target (rad), to be reached at `t_cmd_target`."""
        self.send_request(mode=JOINT, joint_pos=_vec("joint_pos", joint_pos, self.dof),
                          eef_pose=IDENTITY_POSE, t_cmd_target=_t(t_cmd_target))

    @client_side
    def move_eef(self, eef_pose: Any, t_cmd_target: float | None = None) -> None:
        """End-effector target `[x, y, z, qw, qx, qy, qz]` (m), to be reached at `t_cmd_target`."""
        self.send_request(mode=EEF, joint_pos=np.zeros(self.dof), eef_pose=_vec("eef_pose", eef_pose, 7),
                          t_cmd_target=_t(t_cmd_target))

    def handle_request(self, request: dict[str, Any]) -> None:
        if int(request["mode"]) == EEF:
            self.command_eef(np.asarray(request["eef_pose"]), float(request["t_cmd_target"]))
        else:
            self.command_joints(np.asarray(request["joint_pos"]), float(request["t_cmd_target"]))

    def command_joints(self, joint_pos: np.ndarray, t_cmd_target: float) -> None:
        raise InvalidRequest(self.name, "joint_pos", f"{type(self).__name__} takes no joint targets")

    def command_eef(self, eef_pose: np.ndarray, t_cmd_target: float) -> None:
        raise InvalidRequest(self.name, "eef_pose", f"{type(self).__name__} takes no end-effector targets")


class GripperNode(Node):
    """A parallel gripper, commanded by finger opening in meters (0 = closed). Targets are clipped to
    [0, max_width] before `command_position` sees them."""

    __api__ = ("get_state", "send_request", "move", "max_width")

    def __init__(self, max_width: float, *, rate_hz: float | None = None):
        super().__init__(rate_hz=rate_hz)
        self.width = float(max_width)
        self.example_data = {"position": 0.0, "max_width": self.width}
        self.example_request = {"position": 0.0, "t_cmd_target": 0.0}

    @client_side
    def max_width(self) -> float:
        return self.width

    @client_side
    def move(self, position: float, t_cmd_target: float | None = None) -> None:
        """Opening target in meters."""
        self.send_request(position=float(position), t_cmd_target=_t(t_cmd_target))

    def handle_request(self, request: dict[str, Any]) -> None:
        pos = min(max(float(request["position"]), 0.0), self.width)
        self.command_position(pos, float(request["t_cmd_target"]))

    def command_position(self, position: float, t_cmd_target: float) -> None:
        raise NotImplementedError


class HandNode(Node):
    """A multi-fingered hand, commanded in joint space (rad)."""

    __api__ = ("get_state", "send_request", "move_joints", "num_joints")

    def __init__(self, dof: int, *, rate_hz: float | None = None):
        super().__init__(rate_hz=rate_hz)
        self.dof = int(dof)
        self.example_data = {"joint_pos": np.zeros(self.dof)}
        self.example_request = {"joint_pos": np.zeros(self.dof), "t_cmd_target": 0.0}

    @client_side
    def num_joints(self) -> int:
        return self.dof

    @client_side
    def move_joints(self, joint_pos: Any, t_cmd_target: float | None = None) -> None:
        self.send_request(joint_pos=_vec("joint_pos", joint_pos, self.dof), t_cmd_target=_t(t_cmd_target))

    def handle_request(self, request: dict[str, Any]) -> None:
        self.command_joints(np.asarray(request["joint_pos"]), float(request["t_cmd_target"]))

    def command_joints(self, joint_pos: np.ndarray, t_cmd_target: float) -> None:
        raise NotImplementedError


class HumanoidNode(HandNode):
    """A humanoid's whole body in joint space, plus its base IMU. Gains live in the driver config."""

    def __init__(self, dof: int, *, rate_hz: float | None = None):
        super().__init__(dof, rate_hz=rate_hz)
        self.example_data = {"joint_pos": np.zeros(self.dof), "joint_vel": np.zeros(self.dof),
                             "base_quat": np.array([1.0, 0.0, 0.0, 0.0]), "base_ang_vel": np.zeros(3)}


class CameraNode(Node):
    """A camera publishing RGB (and optionally depth) frames at its own rate."""

    __api__ = ("get_state",)

    def __init__(self, width: int, height: int, *, depth: bool = False, rate_hz: float | None = 30.0):
        super().__init__(rate_hz=rate_hz)
        self.width, self.height, self.has_depth = int(width), int(height), bool(depth)
        self.example_data = {"rgb": np.zeros((self.height, self.width, 3), np.uint8),
                             "intrinsics": np.eye(3)}
        if self.has_depth:
            self.example_data["depth"] = np.zeros((self.height, self.width), np.uint16)
            self.example_data["depth_scale"] = 0.001


class TeleopNode(Node):
    """A teleoperation device giving a spatial velocity, a gripper command and buttons. (A leader arm
    is a teleop-kind node publishing ArmNode's state keys instead.)"""

    __api__ = ("get_state",)
    #: True for a leader arm: it also publishes `joint_pos`, and `rio teleop` mirrors it joint by joint
    #: (rio.teleop.leader_follower) instead of integrating its twist in end-effector space.
    leader_arm: ClassVar[bool] = False

    def __init__(self, buttons: int = 2, *, rate_hz: float | None = 100.0):
        super().__init__(rate_hz=rate_hz)
        self.example_data = {"twist": np.zeros(6), "gripper": 1.0, "buttons": np.zeros(int(buttons), bool)}
