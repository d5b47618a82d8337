"""Stand-ins for kortex's `BaseClient` and `BaseCyclicClient` over a `FakeRobot`: the calls the driver
makes, with kortex's names, units (degrees, degrees/s, m; actuator positions reported in [0, 360)) and
refusals (`FakeServerError` where kortex raises `KServerException`); with the robot's link dropped
every call fails in transport (`FakeLinkError`, kortex's `KClientException`)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import messages as pb
from .robot import FakeRobot, FakeServerError


class FakeBase:
    def __init__(self, robot: FakeRobot):
        self.robot = robot

    def _go(self, what: str) -> FakeRobot:
        r = self.robot
        r.advance()
        r.check(what)
        return r

    # -- notifications ---------------------------------------------------------------------------------
    def OnNotificationArmStateTopic(self, callback, options) -> int:  # noqa: N802 (kortex's names)
        self.robot.arm_state_callbacks.append(callback)
        return len(self.robot.arm_state_callbacks)

    def OnNotificationActionTopic(self, callback, options) -> int:  # noqa: N802
        self.robot.action_callbacks.append(callback)
        return len(self.robot.action_callbacks)

    def Unsubscribe(self, handle) -> None:  # noqa: N802
        """Subscriptions end with the session (the fake keeps callbacks until the robot is dropped)."""

    # -- state and modes -------------------------------------------------------------------------------
    def GetArmState(self) -> Any:  # noqa: N802
        self.robot.check_link("GetArmState")
        self.robot.advance()
        return pb.Message(active_state=self.robot.state)

    def SetServoingMode(self, info) -> None:  # noqa: N802
        r = self._go("SetServoingMode")
        r.servoing = info.servoing_mode
        r.low_target = None
        r.speed_cmd[:] = 0.0

    def ClearFaults(self) -> None:  # noqa: N802
        self.robot.check_link("ClearFaults")
        self.robot.advance()
        self.robot.clear()

    def Stop(self) -> None:  # noqa: N802
        self.robot.check_link("Stop")
        self.robot.advance()
        self.robot.speed_cmd[:] = 0.0

    # -- motion ----------------------------------------------------------------------------------------
    def SendJointSpeedsCommand(self, speeds) -> None:  # noqa: N802
        r = self._go("SendJointSpeedsCommand")
        if r.servoing != pb.SINGLE_LEVEL_SERVOING:
            raise FakeServerError("SendJointSpeedsCommand: not in single-level servoing")
        for js in speeds.joint_speeds:
            r.speed_cmd[int(js.joint_identifier)] = math.radians(float(js.value))

    def SendTwistCommand(self, cmd) -> None:  # noqa: N802
        r = self._go("SendTwistCommand")
        t = cmd.twist
        twist = np.array([t.linear_x, t.linear_y, t.linear_z, *np.radians([t.angular_x, t.angular_y, t.angular_z])],
                         dtype=np.float64)
        r.speed_cmd[:] = r.twist_to_speeds(twist)

    def SendGripperCommand(self, cmd) -> None:  # noqa: N802
        r = self._go("SendGripperCommand")
        if cmd.mode != pb.GRIPPER_POSITION:
            raise FakeServerError("SendGripperCommand: the fake takes GRIPPER_POSITION only")
        r.grip_goal = float(np.clip(cmd.gripper.finger[0].value, 0.0, 1.0))

    def GetMeasuredGripperMovement(self, request) -> Any:  # noqa: N802
        r = self.robot
        r.check_link("GetMeasuredGripperMovement")
        r.advance()
        g = pb.Base_pb2.Gripper()
        g.finger.add(finger_identifier=1, value=r.grip)
        return g


class FakeCyclic:
    def __init__(self, robot: FakeRobot):
        self.robot = robot

    def _feedback(self) -> Any:
        r = self.robot
        q, v = r.measured()
        fb = pb.BaseCyclic_pb2.Feedback()
        for qi, vi in zip(q, v, strict=True):
            fb.actuators.add(position=math.degrees(qi) % 360.0, velocity=math.degrees(vi), torque=0.0)
        x, y, z, tx, ty, tz = r.tool_pose(q)
        b = fb.base
        b.tool_pose_x, b.tool_pose_y, b.tool_pose_z = x, y, z
        b.tool_pose_theta_x, b.tool_pose_theta_y, b.tool_pose_theta_z = tx, ty, tz
        b.active_state = r.state
        fb.interconnect.gripper_feedback.motor.add(position=100.0 * r.grip)
        return fb

    def RefreshFeedback(self) -> Any:  # noqa: N802
        self.robot.check_link("RefreshFeedback")
        self.robot.advance()
        return self._feedback()

    def Refresh(self, command) -> Any:  # noqa: N802
        r = self.robot
        r.advance()
        r.check("Refresh")
        if r.servoing != pb.LOW_LEVEL_SERVOING:
            raise FakeServerError("Refresh: not in low-level servoing")
        target = np.radians([a.position for a in command.actuators])
        # the base takes each target as the nearest turn to where the joint is (positions wrap at 360)
        r.low_target = r.q + (target - r.q + math.pi) % (2 * math.pi) - math.pi
        return self._feedback()
