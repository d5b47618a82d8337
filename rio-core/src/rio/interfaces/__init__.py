"""Standard node kinds: the state keys, request keys, client methods and safety every driver of a kind
shares, so an embodiment (and a user's main loop) can drive any arm, gripper, camera, hand or humanoid
without knowing which vendor is behind it (and a mobile base: `BaseNode`, commanded by its body twist).

A driver subclasses one of these, extends its `Config`, and writes only hardware logic: for the
joint kinds `read_joints()` / `write_joints(q)` (plus `set_enabled`, `hardware_limits`,
`robot_description` where the hardware has them); for a gripper `read_width()` / `write_width()`.
The kind owns the rest: the `JointCommander` (interpolation to `t_cmd_target`, limit clipping,
maximum step per cycle, stale-command watchdog), enable/disable, home, and forward kinematics from
`robot_description()` when the hardware reports no end-effector pose. See docs/drivers.md.

Units are SI everywhere: meters, radians, seconds. Poses are `[x, y, z, qw, qx, qy, qz]` (meters,
unit quaternion, scalar first) in the robot's base frame. `t_cmd_target` is a `rio.clock.now()` time
at which the target should be reached; None means "as soon as possible" (sent as the current time).

| kind     | state (`get_state()`; commandable kinds add `enabled`, `holding`)      | client call |
|----------|----------------------------------------------------------------------|-------------|
| arm      | joint_pos (n) rad, joint_vel (n) rad/s, eef_pose (7)                  | move_joints, move_eef |
| gripper  | position m (finger opening), max_width m                              | move(position_m, t, force=None) |
| hand     | joint_pos (n) rad                                                     | move_joints(q, t) |
| humanoid | joint_pos (n), joint_vel (n), base_quat (4, wxyz), base_ang_vel (3) rad/s | move_joints(q, t) |
| camera   | rgb (H,W,3) uint8, intrinsics (3,3); depth (H,W) uint16, depth_scale m | - |
| teleop   | twist (6: m/s, rad/s), gripper (0 closed .. 1 open), buttons (n)     | - |
| wrench   | force (3) N, torque (3) N m in the sensor frame (a `sensor` role)    | tare, untare |
| base     | wheel_pos (n) rad, wheel_vel (n) rad/s, body_twist (3), odom_pose (3)  | move_twist(twist, t) |

A base's `body_twist` is `[vx, vy, wz]` (m/s, rad/s, its own frame), `odom_pose` `[x, y, theta]` (m, rad).

A camera may also publish its lens distortion (`CameraNode.declare_distortion()`): `distortion_model`
(index into `rio.schema.DISTORTION_MODELS`) and `distortion` (5 coefficients).

A humanoid or hand on its low-level topics stops itself soft (kp = 0) when its state goes silent, it
falls or its stream of commands stops: `rio.interfaces.damping`.

What a driver's hardware has besides its kind is a part the node holds, not a class to inherit: faults it
reports (`FaultHolder`), a connection that can drop (`LinkSupervisor`), damping stops (`DampingGuard`), a
camera's grab thread (`Grabber`). Settings every network device or serial bus has are one model each
(`NetworkDevice`, `ServoBus`, in `rio.interfaces.devices`); a vendor's family of arms is a `ModelTable`.

Every sample also carries `timestamp` (added by the runtime). A value a driver cannot measure is
published as NaN, never as a made-up number.
"""

from rio.interfaces.arm import EEF, IDENTITY_POSE, JOINT, ArmNode
from rio.interfaces.base import BaseNode
from rio.interfaces.camera import CameraNode
from rio.interfaces.damping import BodyDampingConfig, DampingConfig, DampingGuard, MotorGainsConfig, motor_gains
from rio.interfaces.devices import IPv4, NetworkDevice, ServoBus
from rio.interfaces.faults import FAULT_KEYS, Fault, FaultHolder
from rio.interfaces.grabber import CameraError, Grabber, SourceFinished, SourceLost
from rio.interfaces.gripper import GripperNode
from rio.interfaces.hand import HandNode, HumanoidNode
from rio.interfaces.joints import JointNode
from rio.interfaces.link import LinkSupervisor
from rio.interfaces.model_table import ModelTable
from rio.interfaces.teleop import TeleopNode
from rio.interfaces.wrench import WrenchNode

__all__ = ["ArmNode", "BaseNode", "GripperNode", "HandNode", "HumanoidNode", "CameraNode", "TeleopNode", "WrenchNode",
           "JointNode",
           "JOINT", "EEF", "IDENTITY_POSE", "Fault", "FaultHolder", "FAULT_KEYS", "LinkSupervisor", "ModelTable",
           "NetworkDevice", "ServoBus", "IPv4", "Grabber", "CameraError", "SourceLost", "SourceFinished",
           "DampingGuard", "DampingConfig", "BodyDampingConfig", "MotorGainsConfig", "motor_gains"]


#: Names this package had before its mixins became parts a node holds, and what a driver writes instead.
_MOVED = {
    "FaultHolding": "give the node a FaultHolder in setup(): self.faults = FaultHolder(self, device, ask=..., "
                    "clear=...) (and a LinkSupervisor for a link that can drop)",
    "DampingSafety": "give the node a DampingGuard and a FaultHolder asking it (rio.interfaces.damping)",
    "ModelTableArm": "set `models = ModelTable(...)` on the ArmNode driver",
    "GrabbingCamera": "make the grabber in open() as self.grabber: the camera kind publishes from it and stops it",
}


def __getattr__(name: str) -> object:
    if name in _MOVED:
        raise ImportError(f"rio.interfaces.{name} is gone: {_MOVED[name]} (docs/drivers.md)")
    raise AttributeError(f"module 'rio.interfaces' has no attribute '{name}'")
