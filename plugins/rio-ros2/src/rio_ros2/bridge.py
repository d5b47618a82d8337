"""The bridge: a station's joint devices and cameras as ROS 2 topics, ROS 2 commands as RIO commands.

Per role, under `--namespace` (empty by default): `<role>/joint_states` (sensor_msgs/JointState: arm,
hand, humanoid), `<arm>/eef_pose` (geometry_msgs/PoseStamped in `<arm>_base_link`), `/tf`
(`<arm>_base_link` -> `<arm>_eef`), `<camera>/image_raw` (rgb8), `<camera>/image_raw/compressed` (JPEG),
`<camera>/camera_info`, `<camera>/depth/image_raw` (32FC1 m) in `<camera>_optical_frame`; subscribed:
`<role>/joint_trajectory` (first point -> `move_joints`) and `<arm>/cmd_vel` (tool twist, base frame ->
`move_eef`). The plugin's README has the full table.

Each tick (`rate_hz`) applies the newest command of each device, then publishes every sample that is
new since the last tick, stamped with the time it was taken (`to_ros.wall_stamp`). Commands are checked
on arrival (`commands`) and reach the robot only through its client, so its commander's limits, step
limit and watchdog apply: a `cmd_vel` stream that stops (no message for `twist_timeout_s`) stops
being integrated, and the arm holds.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from rio import clock
from rio.control.teleop import TeleopMode, make_teleop_eef_cmd
from rio.errors import RioError
from rio.station import roles as R

from . import to_ros
from .commands import Drops, Rejected, trajectory_target, twist_vector
from .rmw import RosNode

log = logging.getLogger("rio.ros2")

JOINT_KINDS = ("arm", "hand", "humanoid")
IMAGES = ("raw", "compressed", "both")


@dataclass(frozen=True)
class BridgeOptions:
    rate_hz: float = 30.0
    namespace: str = ""             # topic prefix ("/lab1"); empty: topics start at the role
    images: str = "raw"             # raw | compressed | both
    jpeg_quality: int = 90
    max_pos_speed: float = 0.15     # m/s: cmd_vel is limited to this ...
    max_rot_speed: float = 1.0      # rad/s ... and this
    twist_timeout_s: float = 0.5    # a cmd_vel older than this is no longer followed
    commands: bool = True           # False: publish only; subscribe to no command topic

    def __post_init__(self) -> None:
        if self.images not in IMAGES:
            raise ValueError(f"images must be one of {', '.join(IMAGES)}, got {self.images!r}")
        if self.namespace and (not self.namespace.startswith("/") or self.namespace.endswith("/")):
            raise ValueError(f"namespace {self.namespace!r} must look like /name (a leading slash, none trailing)")


def bridged_roles(roles: Any) -> list[str]:
    """The roles the bridge publishes: joint devices and cameras."""
    return sorted(r for r in roles if R.kind_of(r) in (*JOINT_KINDS, "camera"))


class _Joints:
    """One joint device (arm, hand, humanoid): its state topics and its command subscriptions."""

    def __init__(self, bridge: Bridge, role: str, client: Any):
        self.bridge, self.role, self.client = bridge, role, client
        self.names = [str(n) for n in client.joint_names()]
        self.is_arm = R.kind_of(role) == "arm"
        ros, base = bridge.ros, bridge.topic(role)
        self.base_frame, self.eef_frame = bridge.frame(f"{role}_base_link"), bridge.frame(f"{role}_eef")
        self.js = ros.publisher(f"{base}/joint_states", "sensor_msgs/msg/JointState")
        self.pose = ros.publisher(f"{base}/eef_pose", "geometry_msgs/msg/PoseStamped") if self.is_arm else None
        self.traj_topic, self.twist_topic = f"{base}/joint_trajectory", f"{base}/cmd_vel"
        if bridge.options.commands:
            ros.subscription(self.traj_topic, "trajectory_msgs/msg/JointTrajectory", self._on_trajectory)
            if self.is_arm:
                ros.subscription(self.twist_topic, "geometry_msgs/msg/Twist", self._on_twist)
        self._lock = threading.Lock()
        self._trajectory: tuple[np.ndarray, float] | None = None  # newest unsent (target, seconds)
        self._twist: tuple[np.ndarray, float] | None = None       # newest (twist, arrival time)
        self.target: np.ndarray | None = None                     # integrated tool target while following cmd_vel
        self.t_twist = 0.0                                        # ... integrated up to this time
        self.v_twist: np.ndarray | None = None                    # ... with this twist, in force until a newer came
        self.last_ts: float | None = None

    # -- zenoh threads: check and keep the newest ------------------------------------------------------
    def _on_trajectory(self, msg: Any) -> None:
        try:
            target = trajectory_target(msg, self.names)
        except Rejected as e:
            self.bridge.drops(self.traj_topic, e)
            return
        if len(msg.points) > 1:
            self.bridge.note(self.traj_topic, "points",
                             f"only a trajectory's first point is followed ({len(msg.points)} points arrived)")
        with self._lock:
            self._trajectory, self._twist = target, None

    def _on_twist(self, msg: Any) -> None:
        try:
            v = twist_vector(msg)
        except Rejected as e:
            self.bridge.drops(self.twist_topic, e)
            return
        with self._lock:
            self._twist = (v, clock.now())

    # -- the bridge's thread ---------------------------------------------------------------------------
    def command(self, sample: Mapping[str, Any], now: float) -> None:
        with self._lock:
            traj, self._trajectory, twist = self._trajectory, None, self._twist
            if not sample.get("enabled", True):
                self._twist = None
        if not sample.get("enabled", True):  # it would refuse them: said once here, not at every message
            why = Rejected("disabled", f"'{self.role}' is disabled (enable it from RIO first)")
            if traj is not None:
                self.bridge.drops(self.traj_topic, why)
            if twist is not None:
                self.bridge.drops(self.twist_topic, why)
            self.target = None
            return
        if traj is not None:
            q, seconds = traj
            self.client.move_joints(q, now + seconds)
            self.target = None
        if twist is None or now - twist[1] > self.bridge.options.twist_timeout_s:
            self.target = None  # no stream, or it stopped: the arm's watchdog holds where it is
            return
        period = 1.0 / self.bridge.options.rate_hz
        if self.target is None:
            if not to_ros.has_pose(sample):
                with self._lock:
                    self._twist = None
                self.bridge.drops(self.twist_topic, Rejected("no pose", f"arm '{self.role}' reports no "
                                                             "end-effector pose to move from"))
                return
            self.target, self.t_twist = np.asarray(sample["eef_pose"], dtype=np.float64).copy(), now
            self.v_twist = None
        # each twist from when it arrived: the one before it until then (a tick after this thread was late
        # moved the newest twist over time before it came); at most two periods after a stall
        o, start = self.bridge.options, max(self.t_twist, now - 2 * period)
        v, t_arrived = twist
        if self.v_twist is not None and t_arrived > start:
            self.target = make_teleop_eef_cmd(self.target, self.v_twist, min(t_arrived, now) - start,
                                              TeleopMode.TRANSLATION_ROTATION, o.max_pos_speed, o.max_rot_speed)
            start = min(t_arrived, now)
        self.target = make_teleop_eef_cmd(self.target, v, max(now - start, 0.0), TeleopMode.TRANSLATION_ROTATION,
                                          o.max_pos_speed, o.max_rot_speed)
        self.t_twist, self.v_twist = now, v
        self.client.move_eef(self.target, now + period)

    def publish(self, sample: Mapping[str, Any], tf: list[Any]) -> None:
        ts = float(sample["timestamp"])
        if ts == self.last_ts:
            return
        self.last_ts, types, stamp = ts, self.bridge.ros.types, to_ros.wall_stamp(ts)
        self.js.publish(to_ros.joint_state(types, self.names, sample, stamp))
        if self.pose is not None and to_ros.has_pose(sample):
            self.pose.publish(to_ros.pose_stamped(types, sample["eef_pose"], self.base_frame, stamp))
            tf.append(to_ros.transform(types, sample["eef_pose"], self.base_frame, self.eef_frame, stamp))

    def tick(self, now: float, tf: list[Any]) -> None:
        sample = self.client.get_state()
        self.command(sample, now)
        self.publish(sample, tf)


class _Camera:
    def __init__(self, bridge: Bridge, role: str, client: Any):
        self.bridge, self.role, self.client = bridge, role, client
        self.base, self.frame_id = bridge.topic(role), bridge.frame(f"{role}_optical_frame")
        images, ros = bridge.options.images, bridge.ros
        self.raw = ros.publisher(f"{self.base}/image_raw", "sensor_msgs/msg/Image") if images != "compressed" else None
        self.jpeg = (ros.publisher(f"{self.base}/image_raw/compressed", "sensor_msgs/msg/CompressedImage")
                     if images != "raw" else None)
        self.info = ros.publisher(f"{self.base}/camera_info", "sensor_msgs/msg/CameraInfo")
        has_depth = "depth" in client.get_state()
        self.depth = ros.publisher(f"{self.base}/depth/image_raw", "sensor_msgs/msg/Image") if has_depth else None
        self.last_ts: float | None = None
        if self.jpeg is not None:
            try:
                import PIL.Image  # noqa: F401
            except ImportError:
                raise RioError("compressed camera topics need Pillow: pip install pillow (or --images raw)") from None

    def tick(self) -> None:
        frame = self.client.newest_frame()  # pixels stay in the ring until read
        ts = float(frame.meta["timestamp"])
        if ts == self.last_ts:
            return
        self.last_ts, types, stamp, o = ts, self.bridge.ros.types, to_ros.wall_stamp(ts), self.bridge.options
        rgb = frame.rgb
        if self.raw is not None:
            self.raw.publish(to_ros.image(types, rgb, self.frame_id, stamp))
        if self.jpeg is not None:
            self.jpeg.publish(to_ros.compressed_image(types, rgb, self.frame_id, stamp, o.jpeg_quality))
        if "intrinsics" in frame.meta:
            h, w = rgb.shape[:2]
            self.info.publish(to_ros.camera_info(types, frame.meta["intrinsics"], w, h, self.frame_id, stamp))
        if self.depth is not None:
            self.depth.publish(to_ros.image(types, frame.depth, self.frame_id, stamp))


class Bridge:
    """`clients`: {role: connected client} of the roles to bridge (`bridged_roles`). Call `tick()` at
    the rate, or `run(stop)`."""

    def __init__(self, clients: Mapping[str, Any], ros: RosNode, options: BridgeOptions | None = None,
                 first_sample_timeout_s: float = 15.0):
        self.ros, self.options = ros, options or BridgeOptions()
        self.drops = Drops()
        self._noted: set[tuple[str, str]] = set()
        _wait_first_samples(clients, first_sample_timeout_s)
        self.joints = [_Joints(self, r, c) for r, c in sorted(clients.items()) if R.kind_of(r) in JOINT_KINDS]
        self.cameras = [_Camera(self, r, c) for r, c in sorted(clients.items()) if R.kind_of(r) == "camera"]
        self.tf = ros.publisher("/tf", "tf2_msgs/msg/TFMessage") if any(j.is_arm for j in self.joints) else None
        self.ticks = 0

    def topic(self, role: str) -> str:
        return f"{self.options.namespace}/{role}"

    def frame(self, name: str) -> str:
        ns = self.options.namespace.strip("/").replace("/", "_")
        return f"{ns}_{name}" if ns else name

    def note(self, topic: str, key: str, what: str) -> None:
        """Log `what` once per topic and key."""
        if (topic, key) not in self._noted:
            self._noted.add((topic, key))
            log.warning("%s: %s", topic, what)

    def tick(self) -> None:
        now = clock.now()
        tf: list[Any] = []
        for j in self.joints:
            j.tick(now, tf)
        if tf and self.tf is not None:
            self.tf.publish(to_ros.tf_message(self.ros.types, tf))
        for c in self.cameras:
            c.tick()
        self.ticks += 1

    def run(self, stop: Callable[[], bool]) -> None:
        """Tick at `rate_hz` until `stop()` is true."""
        rate = clock.Rate(self.options.rate_hz)
        while not stop():
            self.tick()
            rate.sleep()


def _wait_first_samples(clients: Mapping[str, Any], timeout_s: float) -> None:
    """Every node has published (a node is ready before its first sample is in its ring)."""
    deadline = clock.now() + timeout_s
    for role, client in clients.items():
        while True:
            try:
                client.get_state()
                break
            except RioError as e:
                if clock.now() > deadline:
                    raise RioError(f"node '{role}' published nothing in {timeout_s:g} s: {e}") from None
                clock.precise_wait(clock.now() + 0.01)
