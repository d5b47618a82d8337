"""The pure parts, without zenoh: RIO samples -> ROS messages (through CDR and back), ROS commands ->
checked targets, and drops logged once per cause."""

from __future__ import annotations

import logging
import threading
import time
from types import SimpleNamespace as NS

import numpy as np
import pytest
from rio_ros2 import to_ros
from rio_ros2.commands import Drops, Rejected, trajectory_target, twist_vector
from rio_ros2.messages import message_types

from rio import clock

T = message_types("jazzy")


def _roundtrip(msg, name):
    return T.deserialize(T.serialize(msg, name), name)


def test_an_rgb_frame_keeps_its_rows_columns_and_channels():
    rng = np.random.default_rng(0)
    rgb = rng.integers(0, 256, (5, 7, 3), dtype=np.uint8)
    img = _roundtrip(to_ros.image(T, rgb, "cam", 12.5), "sensor_msgs/msg/Image")
    assert (img.height, img.width, img.step, img.encoding) == (5, 7, 21, "rgb8")
    np.testing.assert_array_equal(np.asarray(img.data).reshape(5, 7, 3), rgb)


def test_depth_is_32fc1_meters_little_endian():
    depth = np.arange(12, dtype=np.float32).reshape(3, 4) / 10
    img = _roundtrip(to_ros.image(T, depth, "cam", 1.0), "sensor_msgs/msg/Image")
    assert (img.encoding, img.step, img.is_bigendian) == ("32FC1", 16, 0)
    np.testing.assert_array_equal(np.frombuffer(bytes(img.data), "<f4").reshape(3, 4), depth)
    with pytest.raises(ValueError, match="no ROS image encoding"):
        to_ros.image(T, np.zeros((2, 2, 4), np.uint8), "cam", 1.0)


def test_stamps_are_the_samples_capture_time_on_the_wall_clock():
    t_sample = clock.now() - 0.25  # taken a quarter second ago
    assert abs(to_ros.wall_stamp(t_sample) - (time.time() - 0.25)) < 0.01
    stamp = T.time(1_700_000_000.123456789)
    assert stamp.sec == 1_700_000_000 and abs(stamp.nanosec - 123_456_789) < 1000


def test_pose_order_is_converted_from_rio_wxyz_to_ros_xyzw():
    pose = np.array([0.1, 0.2, 0.3, 0.9, 0.1, 0.2, 0.3])
    msg = _roundtrip(to_ros.pose_stamped(T, pose, "arm_base_link", 5.0), "geometry_msgs/msg/PoseStamped")
    o = msg.pose.orientation
    assert (o.w, o.x, o.y, o.z) == (0.9, 0.1, 0.2, 0.3)
    assert not to_ros.has_pose({"eef_pose": np.full(7, np.nan)}) and to_ros.has_pose({"eef_pose": pose})


def test_unmeasured_velocities_are_left_empty():
    names = ["a", "b"]
    msg = to_ros.joint_state(T, names, {"joint_pos": np.ones(2), "joint_vel": np.full(2, np.nan)}, 1.0)
    assert len(msg.velocity) == 0 and list(msg.position) == [1.0, 1.0]


def _traj(names, positions, sec=1, nanosec=0, points=1):
    pt = NS(positions=np.asarray(positions, dtype=np.float64), time_from_start=NS(sec=sec, nanosec=nanosec))
    return NS(joint_names=names, points=[pt] * points)


def test_a_trajectorys_first_point_is_reordered_to_the_nodes_joints():
    q, t = trajectory_target(_traj(["b", "c", "a"], [2.0, 3.0, 1.0], sec=1, nanosec=500_000_000), ["a", "b", "c"])
    np.testing.assert_array_equal(q, [1.0, 2.0, 3.0])
    assert t == 1.5


@pytest.mark.parametrize("msg,cause", [
    (_traj(["a", "b"], [1.0, 2.0]), "joint names"),
    (_traj(["a", "b", "x"], [1.0, 2.0, 3.0]), "joint names"),
    (_traj(["a", "a", "b"], [1.0, 2.0, 3.0]), "joint names"),
    (_traj(["a", "b", "c"], [1.0, 2.0]), "positions"),
    (_traj(["a", "b", "c"], [1.0, np.nan, 3.0]), "not finite"),
    (_traj(["a", "b", "c"], [1.0, 2.0, -np.inf]), "not finite"),
    (_traj(["a", "b", "c"], [1.0, 2.0, 3.0], sec=-1), "time"),
    (_traj(["a", "b", "c"], [1.0, 2.0, 3.0], points=0), "no points"),
])
def test_malformed_trajectories_are_rejected_with_their_cause(msg, cause):
    with pytest.raises(Rejected) as e:
        trajectory_target(msg, ["a", "b", "c"])
    assert e.value.cause == cause


def test_twists_must_be_finite():
    v = NS(x=0.1, y=0.0, z=0.0)
    np.testing.assert_array_equal(twist_vector(NS(linear=v, angular=NS(x=0.0, y=0.0, z=0.3))),
                                  [0.1, 0, 0, 0, 0, 0.3])
    with pytest.raises(Rejected, match="NaN"):
        twist_vector(NS(linear=v, angular=NS(x=np.nan, y=0.0, z=0.0)))


def test_drops_are_counted_and_logged_once_per_topic_and_cause(caplog):
    caplog.set_level(logging.WARNING, logger="rio.ros2")
    drops = Drops()
    for _ in range(3):
        drops("/arm/joint_trajectory", Rejected("joint names", "joint names [x] are not ..."))
    drops("/arm/joint_trajectory", Rejected("not finite", "NaN"))
    drops("/arm2/joint_trajectory", Rejected("joint names", "joint names [y] are not ..."))
    assert drops.counts[("/arm/joint_trajectory", "joint names")] == 3
    assert drops.total("/arm/joint_trajectory") == 4 and drops.total() == 5
    assert len(caplog.records) == 3
    assert all("not sent to the robot" in r.getMessage() for r in caplog.records)


def test_each_cmd_vel_twist_moves_the_tool_only_from_when_it_arrived():
    """The bridge's thread late by 60 ms, a new twist arriving 10 ms before it runs: the tool target moves by
    the old twist until the new one came and by the new one after, not by the new one over the whole gap
    (which moved it for time before it came). Explicit times, so the figures are exact."""
    from rio_ros2.bridge import BridgeOptions, _Joints

    sent = []
    joints = _Joints.__new__(_Joints)  # the command path only: no ROS node behind it
    joints.bridge, joints.role = NS(options=BridgeOptions(rate_hz=10.0), drops=None), "arm"
    joints.client = NS(move_eef=lambda pose, t: sent.append(np.array(pose)))
    joints._lock, joints._trajectory = threading.Lock(), None
    joints.target, joints.t_twist, joints.v_twist = None, 0.0, None
    sample = {"enabled": True, "eef_pose": np.array([0.4, 0.0, 0.3, 1.0, 0.0, 0.0, 0.0])}
    forward, sideways = np.array([0.1, 0, 0, 0, 0, 0]), np.array([0, 0.1, 0, 0, 0, 0])
    joints._twist = (forward, 10.0)
    joints.command(sample, 10.0)  # the stream starts: the target is where the tool is
    joints.command(sample, 10.1)  # 0.1 s of forward
    joints._twist = (sideways, 10.15)
    joints.command(sample, 10.16)  # 50 ms more of forward, then 10 ms of sideways
    np.testing.assert_allclose(sent[-1][:3], [0.4 + 0.1 * 0.15, 0.1 * 0.01, 0.3], atol=1e-12)
