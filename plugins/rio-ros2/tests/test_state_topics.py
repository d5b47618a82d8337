"""What a ROS 2 subscriber receives from a bridged station: zenoh-ros2-sdk's subscribers (rmw_zenoh's
wire format, decoded by their own CDR code) get the arm's joint state, its end-effector pose and TF,
and the camera's images, each equal to what the station itself reports."""

from __future__ import annotations

import time

import numpy as np
import pytest

from rio import clock
from rio.testing import wait_until

NAMES = [f"joint{i}" for i in range(1, 7)]
Q = np.array([0.3, -0.2, 0.5, 0.1, -0.4, 0.25])


def _stamp(msg) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


@pytest.fixture(scope="module")
def still_arm(running):
    """The arm moved (by RIO itself) to Q and resting there, so ROS and RIO must agree exactly."""
    with running.factories["arm"]() as arm:
        arm.move_joints(Q, clock.now() + 0.5)
        assert wait_until(lambda: np.allclose(arm.get_state()["joint_pos"], Q, atol=1e-9), timeout=30)
        yield arm.get_state()


def test_joint_states_carry_the_arms_names_and_positions(running, still_arm, inbox):
    inbox.subscribe("/arm/joint_states", "sensor_msgs/msg/JointState")
    msg = inbox.wait("/arm/joint_states", lambda m: np.allclose(m.position, Q, atol=1e-9))
    assert list(msg.name) == NAMES
    np.testing.assert_allclose(msg.position, still_arm["joint_pos"], atol=1e-9)
    assert len(msg.velocity) in (0, 6) and len(msg.effort) == 0
    assert abs(_stamp(msg) - time.time()) < 30  # wall clock (UNIX epoch), not RIO's monotonic clock


def test_eef_pose_and_tf_are_the_arms_tool_pose(running, still_arm, inbox):
    inbox.subscribe("/arm/eef_pose", "geometry_msgs/msg/PoseStamped")
    inbox.subscribe("/tf", "tf2_msgs/msg/TFMessage")
    x, y, z, qw, qx, qy, qz = still_arm["eef_pose"]

    pose = inbox.wait("/arm/eef_pose", lambda m: abs(m.pose.position.x - x) < 1e-9)
    p, o = pose.pose.position, pose.pose.orientation
    assert pose.header.frame_id == "arm_base_link"
    np.testing.assert_allclose([p.x, p.y, p.z, o.x, o.y, o.z, o.w], [x, y, z, qx, qy, qz, qw], atol=1e-9)

    tf = inbox.wait("/tf", lambda m: abs(m.transforms[0].transform.translation.x - x) < 1e-9)
    [t] = tf.transforms
    assert (t.header.frame_id, t.child_frame_id) == ("arm_base_link", "arm_eef")
    r, v = t.transform.rotation, t.transform.translation
    np.testing.assert_allclose([v.x, v.y, v.z, r.x, r.y, r.z, r.w], [x, y, z, qx, qy, qz, qw], atol=1e-9)
    assert abs(_stamp(t) - _stamp(pose)) < 1.0


def test_camera_images_are_the_cameras_frames(running, inbox):
    for topic, typ in [("/front_camera/image_raw", "sensor_msgs/msg/Image"),
                       ("/front_camera/image_raw/compressed", "sensor_msgs/msg/CompressedImage"),
                       ("/front_camera/camera_info", "sensor_msgs/msg/CameraInfo"),
                       ("/front_camera/depth/image_raw", "sensor_msgs/msg/Image")]:
        inbox.subscribe(topic, typ)
    img = inbox.wait("/front_camera/image_raw")
    assert (img.width, img.height, img.encoding, img.step, img.is_bigendian) == (64, 48, "rgb8", 64 * 3, 0)
    assert img.header.frame_id == "front_camera_optical_frame"
    pixels = np.asarray(img.data, dtype=np.uint8).reshape(48, 64, 3)
    with running.factories["front_camera"]() as cam:
        recent = cam.get_state(k=60)["rgb"]  # the frames the camera published lately, oldest first
        k = cam.get_state()["intrinsics"]
    assert any(np.array_equal(pixels, frame) for frame in recent), "the image is none of the camera's frames"

    info = inbox.wait("/front_camera/camera_info")
    assert (info.width, info.height, info.header.frame_id) == (64, 48, "front_camera_optical_frame")
    np.testing.assert_allclose(np.asarray(info.k).reshape(3, 3), k)

    depth = inbox.wait("/front_camera/depth/image_raw")
    assert (depth.width, depth.height, depth.encoding, depth.step) == (64, 48, "32FC1", 64 * 4)
    np.testing.assert_allclose(np.frombuffer(bytes(depth.data), "<f4"), 1.0)  # the fake's flat 1 m

    jpeg = inbox.wait("/front_camera/image_raw/compressed")
    assert "jpeg" in jpeg.format and bytes(jpeg.data[:2]) == b"\xff\xd8"


def test_teleop_devices_are_not_started(running):
    assert sorted(h.name for h in running.manager.handles) == ["arm", "front_camera"]  # ROS commands, not it
