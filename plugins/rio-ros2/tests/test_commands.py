"""Commands from ROS 2 (zenoh-ros2-sdk's publisher, as `ros2 topic pub` would send them) move the
station's arm through its own commander, and malformed ones never reach it."""

from __future__ import annotations

import time

import numpy as np
import pytest

from rio import clock
from rio.testing import wait_until

NAMES = [f"joint{i}" for i in range(1, 7)]


def _trajectory(types, names, positions, seconds=0.5, points=1):
    point = types["trajectory_msgs/msg/JointTrajectoryPoint"]
    duration = types["builtin_interfaces/msg/Duration"]
    empty = np.zeros(0)
    header = types["std_msgs/msg/Header"](stamp=types["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id="")
    pts = [point(positions=np.asarray(positions, dtype=np.float64), velocities=empty, accelerations=empty,
                 effort=empty, time_from_start=duration(sec=int(seconds), nanosec=int(seconds % 1 * 1e9)))
           for _ in range(points)]
    return {"header": header, "joint_names": list(names), "points": pts}


def _publish_until(pub, msg, pred, every=0.1, timeout=30.0):
    """Publish `msg` every `every` s until `pred()` (a first message may go out before its route exists)."""
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        pub.publish(**msg)
        if wait_until(pred, timeout=every):
            return True
    return False


def _settled(arm) -> np.ndarray:
    """The arm's position once it stopped moving."""
    last = [arm.get_state()["joint_pos"].copy()]

    def still():
        q = arm.get_state()["joint_pos"].copy()
        same, last[0] = np.allclose(q, last[0], atol=1e-12), q
        return same and arm.get_state()["holding"]

    assert wait_until(still, timeout=30, period=0.2)
    return last[0]


@pytest.fixture
def trajectories(sdk_publisher):
    pub = sdk_publisher("/arm/joint_trajectory", "trajectory_msgs/msg/JointTrajectory")
    return pub, sdk_publisher.types()


def test_a_joint_trajectory_moves_the_arm(running, arm, trajectories, inbox):
    pub, types = trajectories
    target = np.array([0.4, -0.3, 0.2, 0.6, -0.1, 0.35])
    order = [5, 0, 3, 1, 4, 2]  # ROS joint order need not be the arm's
    msg = _trajectory(types, [NAMES[i] for i in order], target[order], seconds=0.5)
    assert _publish_until(pub, msg, lambda: np.allclose(arm.get_state()["joint_pos"], target, atol=1e-6), every=3.0)
    inbox.subscribe("/arm/joint_states", "sensor_msgs/msg/JointState")
    inbox.wait("/arm/joint_states", lambda m: np.allclose(m.position, target, atol=1e-6))


def test_targets_beyond_the_limits_are_clipped_by_the_arms_commander(running, arm, trajectories):
    pub, types = trajectories
    far = np.full(6, 5.0)  # the station limits every joint to [-2, 2]
    msg = _trajectory(types, NAMES, far, seconds=0.2)
    assert _publish_until(pub, msg, lambda: np.allclose(arm.get_state()["joint_pos"], 2.0, atol=1e-6), every=3.0)
    time.sleep(0.5)
    assert np.all(arm.get_state()["joint_pos"] <= 2.0 + 1e-9)


@pytest.mark.parametrize("cause,names,positions", [
    ("joint names", [f"j{i}" for i in range(6)], [0.1] * 6),
    ("joint names", NAMES[:5], [0.1] * 5),
    ("joint names", NAMES[:5] + NAMES[:1], [0.1] * 6),
    ("positions", NAMES, [0.1] * 5),
    ("not finite", NAMES, [0.1, np.nan, 0.1, 0.1, 0.1, 0.1]),
    ("not finite", NAMES, [0.1, 0.1, np.inf, 0.1, 0.1, 0.1]),
])
def test_a_malformed_trajectory_does_not_move_the_arm(running, arm, trajectories, cause, names, positions):
    pub, types = trajectories
    before = _settled(arm)
    drops = running.bridge.drops
    n0 = drops.counts[("/arm/joint_trajectory", cause)]
    msg = _trajectory(types, names, positions)
    assert _publish_until(pub, msg, lambda: drops.counts[("/arm/joint_trajectory", cause)] >= n0 + 3)
    time.sleep(0.5)
    np.testing.assert_array_equal(arm.get_state()["joint_pos"], before)


def test_a_trajectory_without_points_or_going_back_in_time_does_not_move_the_arm(running, arm, trajectories):
    pub, types = trajectories
    before = _settled(arm)
    drops = running.bridge.drops
    empty = _trajectory(types, NAMES, [0.0] * 6, points=0)
    assert _publish_until(pub, empty, lambda: drops.counts[("/arm/joint_trajectory", "no points")] >= 2)
    back = _trajectory(types, NAMES, [0.0] * 6)
    back["points"][0].time_from_start.sec = -2
    assert _publish_until(pub, back, lambda: drops.counts[("/arm/joint_trajectory", "time")] >= 2)
    time.sleep(0.5)
    np.testing.assert_array_equal(arm.get_state()["joint_pos"], before)


def test_cmd_vel_moves_the_tool_and_the_arm_holds_when_it_stops(running, arm, sdk_publisher):
    pub = sdk_publisher("/arm/cmd_vel", "geometry_msgs/msg/Twist")
    types = sdk_publisher.types()
    vec = types["geometry_msgs/msg/Vector3"]
    x0 = arm.get_state()["eef_pose"][0]
    msg = {"linear": vec(x=0.05, y=0.0, z=0.0), "angular": vec(x=0.0, y=0.0, z=0.0)}
    assert _publish_until(pub, msg, lambda: arm.get_state()["eef_pose"][0] > x0 + 0.01)
    # the stream stops: the bridge stops integrating after twist_timeout_s, the arm's commander holds
    time.sleep(running.bridge.options.twist_timeout_s + 0.5)
    x1 = arm.get_state()["eef_pose"][0]
    time.sleep(0.5)
    assert abs(arm.get_state()["eef_pose"][0] - x1) < 1e-9

    bad = {"linear": vec(x=float("nan"), y=0.0, z=0.0), "angular": vec(x=0.0, y=0.0, z=0.0)}
    drops = running.bridge.drops
    assert _publish_until(pub, bad, lambda: drops.counts[("/arm/cmd_vel", "not finite")] >= 3)
    time.sleep(0.5)
    assert abs(arm.get_state()["eef_pose"][0] - x1) < 1e-9
    assert np.isfinite(arm.get_state()["eef_pose"]).all()


def test_the_arms_own_moves_are_not_disturbed_by_an_idle_bridge(running, arm):
    q = np.full(6, -0.2)
    arm.move_joints(q, clock.now() + 0.3)
    assert wait_until(lambda: np.allclose(arm.get_state()["joint_pos"], q, atol=1e-9), timeout=30)


def test_commands_to_a_disabled_arm_are_dropped_by_the_bridge(running, arm, trajectories):
    pub, types = trajectories
    before = _settled(arm)
    arm.disable()
    try:
        drops = running.bridge.drops
        msg = _trajectory(types, NAMES, before + 0.1)
        assert _publish_until(pub, msg, lambda: drops.counts[("/arm/joint_trajectory", "disabled")] >= 2)
        time.sleep(0.5)
        np.testing.assert_array_equal(arm.get_state()["joint_pos"], before)
    finally:
        arm.enable()


def test_bytes_that_are_no_message_are_dropped(running, arm, ros_port):
    """A peer that puts garbage (or far too much) on the command key expression moves nothing."""
    from rio_ros2.rmw import Subscription
    from zenoh_ros2_sdk import ZenohSession

    [sub] = [e for e in running.bridge.ros.endpoints
             if isinstance(e, Subscription) and e.topic == "/arm/joint_trajectory"]
    before = _settled(arm)
    raw = ZenohSession.get_instance().session
    for payload in (b"\x00\x01\x00\x00garbage", b"\x00\x01\x00\x00" + b"\xff" * (2 << 20)):
        n0 = sub.dropped
        assert wait_until(lambda p=payload, n=n0: raw.put(sub.keyexpr, p) or sub.dropped > n, timeout=30, period=0.2)
    time.sleep(0.5)
    np.testing.assert_array_equal(arm.get_state()["joint_pos"], before)
