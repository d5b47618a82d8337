"""`rio ros2 bridge` as a user runs it: a fresh process that starts the station, shows up on the ROS
side (the SDK's subscriber on another domain than the module's bridge) and stops cleanly on Ctrl-C,
its nodes included."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import numpy as np

from rio.cli import main
from rio.plugins import Registry


def test_the_plugin_adds_rio_ros2_and_its_requirements():
    reg = Registry()
    assert not [p for p in reg.problems if "ros2" in p.plugin], reg.problems
    assert {r.module for r in reg.requirements()["rio-ros2"]} == {"zenoh", "rosbags", "PIL"}
    assert main(["ros2", "--help"]) == 0


def test_rio_ros2_bridge_runs_a_station_until_ctrl_c(ros_port, station_file, domain, inbox):
    inbox.domain = domain + 1  # a graph of its own: the module's bridge publishes the same topics
    inbox.subscribe("/lab/arm/joint_states", "sensor_msgs/msg/JointState")
    proc = subprocess.Popen(
        [sys.executable, "-m", "rio", "ros2", "bridge", str(station_file), "--domain", str(domain + 1),
         "--connect", f"tcp/127.0.0.1:{ros_port}", "--namespace", "/lab", "--rate", "20", "--duration", "240",
         "--middleware", "shm"],  # nodes in processes of their own (the module's bridge: threads)
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, stdin=subprocess.DEVNULL,
        env={**os.environ, "ROS_DOMAIN_ID": "99"})  # --domain wins over the environment
    try:
        msg = inbox.wait("/lab/arm/joint_states", timeout=180)
        assert list(msg.name) == [f"joint{i}" for i in range(1, 7)] and np.allclose(msg.position, 0.0)
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 128 + signal.SIGINT, out
    assert "ROS 2 node /rio_ros2_test (domain 18, jazzy)" in out
    assert "pub /lab/arm/joint_states  [sensor_msgs/msg/JointState]" in out
    assert "sub /lab/arm/cmd_vel  [geometry_msgs/msg/Twist]" in out
    assert "stopped by SIGINT" in out


def test_bad_arguments_are_named_before_anything_starts(station_file, tmp_path, capsys):
    assert main(["ros2", "bridge", str(station_file), "--connect", "localhost"]) == 2
    assert "not a zenoh endpoint" in capsys.readouterr().err
    assert main(["ros2", "bridge", str(station_file), "--namespace", "lab"]) == 2
    assert main(["ros2", "bridge", str(station_file), "--distro", "groovy"]) == 2
    lonely = tmp_path / "teleop-only.toml"
    lonely.write_text('name = "lonely"\n[middleware]\nname = "thread"\n'
                      '[components.teleop]\ndriver = "rio.fake_teleop"\n')
    assert main(["ros2", "bridge", str(lonely)]) != 0
    assert "no arm, hand, humanoid or camera to bridge" in capsys.readouterr().err
