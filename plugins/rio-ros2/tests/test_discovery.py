"""The ROS 2 graph as rmw_zenoh peers build it, from liveliness tokens: zenoh-ros2-sdk's discovery (what
its `ros2 topic list` / `topic info -v` run) sees the bridge's node, its publishers and subscriptions
with the right types and type hashes, and sees them go when the bridge goes."""

from __future__ import annotations

import pytest
from rio_ros2.messages import message_types
from rio_ros2.rmw import RosNode

from rio.testing import wait_until

PUBLISHED = {
    "/arm/joint_states": "sensor_msgs/msg/JointState",
    "/arm/eef_pose": "geometry_msgs/msg/PoseStamped",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/front_camera/image_raw": "sensor_msgs/msg/Image",
    "/front_camera/image_raw/compressed": "sensor_msgs/msg/CompressedImage",
    "/front_camera/camera_info": "sensor_msgs/msg/CameraInfo",
    "/front_camera/depth/image_raw": "sensor_msgs/msg/Image",
}
SUBSCRIBED = {
    "/arm/joint_trajectory": "trajectory_msgs/msg/JointTrajectory",
    "/arm/cmd_vel": "geometry_msgs/msg/Twist",
}


def _topics(port, domain):
    from zenoh_ros2_sdk import get_topic_names_and_types

    return dict(get_topic_names_and_types(domain_id=domain, router_port=port, timeout=2.0))


def _nodes(domain):
    from zenoh_ros2_sdk import ZenohSession

    replies = ZenohSession.get_instance().liveliness.get(f"@ros2_lv/{domain}/*/*/*/NN/**", timeout=2.0)
    return {str(r.ok.key_expr).split("/")[-1] for r in replies if r.ok is not None}


def test_the_bridges_topics_are_listed_with_their_types(running, ros_port, domain):
    expected = {**PUBLISHED, **SUBSCRIBED}

    def listed():
        topics = _topics(ros_port, domain)
        return all(topics.get(t) == [typ] for t, typ in expected.items())

    assert wait_until(listed, timeout=30, period=0.5), _topics(ros_port, domain)


def test_topic_info_names_the_bridges_node_and_type_hash(running, ros_port, domain):
    from zenoh_ros2_sdk import get_topic_info

    types = message_types("jazzy")
    assert running.node_name == "rio_ros2_test"
    assert "rio_ros2_test" in _nodes(domain)
    info = get_topic_info("/arm/joint_states", domain_id=domain, router_port=ros_port, timeout=2.0, verbose=True)
    [pub] = [p for p in info.publishers if p.node_name == "rio_ros2_test"]
    assert pub.topic_type == "sensor_msgs/msg/JointState"
    assert pub.type_hash == types.hash("sensor_msgs/msg/JointState")
    assert pub.type_hash == "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e"
    info = get_topic_info("/arm/joint_trajectory", domain_id=domain, router_port=ros_port, timeout=2.0, verbose=True)
    assert [s.node_name for s in info.subscribers] == ["rio_ros2_test"]


def test_a_node_leaves_the_graph_when_closed(ros_port, domain):
    types = message_types("jazzy")
    domain += 2  # a graph of its own
    node = RosNode("rio_short_lived", namespace="/lab", domain=domain, types=types,
                   connect=[f"tcp/127.0.0.1:{ros_port}"])
    try:
        node.publisher("/lab/status", "std_msgs/msg/String")
        assert wait_until(lambda: _topics(ros_port, domain).get("/lab/status") == ["std_msgs/msg/String"],
                          timeout=30, period=0.5)
        assert "rio_short_lived" in _nodes(domain)
    finally:
        node.close()
    assert wait_until(lambda: "/lab/status" not in _topics(ros_port, domain), timeout=30, period=0.5)
    assert "rio_short_lived" not in _nodes(domain)


def test_topic_names_must_be_absolute():
    with RosNode("rio_names", domain=3, types=message_types("jazzy"), connect=[]) as node:
        for bad in ("arm/joint_states", "/arm//x", "/arm/"):
            with pytest.raises(ValueError, match="absolute"):
                node.publisher(bad, "std_msgs/msg/String")


def test_a_read_only_bridge_under_a_namespace(running, ros_port, domain, inbox):
    """A second bridge of the same station: `commands=False` subscribes to nothing; a namespace prefixes
    every topic but /tf and every frame."""
    from rio_ros2.bridge import Bridge, BridgeOptions
    from rio_ros2.rmw import Publisher

    domain += 5
    inbox.domain = domain
    inbox.subscribe("/lab2/arm/eef_pose", "geometry_msgs/msg/PoseStamped")
    inbox.subscribe("/tf", "tf2_msgs/msg/TFMessage")
    with running.factories["arm"]() as arm, \
            RosNode("rio_lab2", domain=domain, types=message_types("jazzy"),
                    connect=[f"tcp/127.0.0.1:{ros_port}"]) as node:
        bridge = Bridge({"arm": arm}, node, BridgeOptions(namespace="/lab2", commands=False))
        assert all(isinstance(e, Publisher) for e in node.endpoints)
        assert sorted(e.topic for e in node.endpoints) == ["/lab2/arm/eef_pose", "/lab2/arm/joint_states", "/tf"]
        assert wait_until(lambda: bridge.tick() or inbox.last("/tf") is not None, timeout=30, period=0.05)
        pose = inbox.wait("/lab2/arm/eef_pose")
        assert pose.header.frame_id == "lab2_arm_base_link"
        assert inbox.last("/tf").transforms[0].child_frame_id == "lab2_arm_eef"
