"""Message definitions with no network: rosbags' typestore gives every standard type, its CDR and its
type hash; the `.msg` files written from it give zenoh-ros2-sdk (whose git fetching the conftest
replaced by a failure) the same definitions, so both sides compute the same key expressions."""

from __future__ import annotations

import pytest
from rio_ros2.messages import NO_TYPE_HASH, dds_name, message_types, msg_text, write_definitions

from rio.cli import main

BRIDGED = ["sensor_msgs/msg/JointState", "sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage",
           "sensor_msgs/msg/CameraInfo", "geometry_msgs/msg/PoseStamped", "tf2_msgs/msg/TFMessage",
           "trajectory_msgs/msg/JointTrajectory", "geometry_msgs/msg/Twist"]


def test_the_sdk_computes_the_same_type_hashes_from_our_definitions(ros_port, domain):
    from zenoh_ros2_sdk import ROS2Publisher

    types = message_types("jazzy")
    for i, name in enumerate(BRIDGED):
        pub = ROS2Publisher(f"/hash_check_{i}", name, domain_id=domain + 4, router_port=ros_port)
        try:
            assert pub.type_hash == types.hash(name), name
            assert pub.dds_type_name == dds_name(name)
        finally:
            pub.close()


def test_type_hashes_match_ros2s_own():
    # the example in rmw_zenoh's design notes: `0/chatter/std_msgs::msg::dds_::String_/RIHS01_df66...`
    assert message_types("jazzy").hash("std_msgs/msg/String") == \
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
    assert dds_name("std_msgs/msg/String") == "std_msgs::msg::dds_::String_"
    assert message_types("humble").hash("std_msgs/msg/String") == NO_TYPE_HASH  # Humble's rmw_zenoh has none


def test_definitions_round_trip_through_rosbags_parser(tmp_path):
    from rosbags.typesys import get_types_from_msg

    types = message_types("jazzy")
    for name in BRIDGED + ["sensor_msgs/msg/NavSatStatus", "std_msgs/msg/Empty"]:
        assert get_types_from_msg(msg_text(types, name), name)[name] == types.store.fielddefs[name]
    root = write_definitions(tmp_path, "jazzy")
    text = (root / "sensor_msgs" / "msg" / "JointState.msg").read_text()
    assert text.splitlines()[:2] == ["std_msgs/Header header", "string[] name"]
    assert len(list(root.glob("*/msg/*.msg"))) == len(types.store.fielddefs)


def test_an_unknown_type_or_distribution_is_named():
    with pytest.raises(KeyError, match="not a standard message"):
        message_types("jazzy").hash("my_msgs/msg/Nope")
    with pytest.raises(ValueError, match="unknown ROS 2 distribution"):
        message_types("groovy")


def test_rio_ros2_definitions_writes_the_files(tmp_path, capsys):
    assert main(["ros2", "definitions", str(tmp_path / "defs"), "--distro", "humble"]) == 0
    assert (tmp_path / "defs" / "trajectory_msgs" / "msg" / "JointTrajectory.msg").is_file()
    assert "ROS 2 humble" in capsys.readouterr().out
