"""`kinova.gen3 | gen3_6dof | gen3_lite`: a Kinova arm on its base, through kortex (`session.py`).

Hardware logic only; the arm kind (`rio.interfaces.ArmNode`) owns the cycle and the safety. Each tick
reads `BaseCyclic.RefreshFeedback` and sends one goal:
- high level (default): joint speeds (`SendJointSpeedsCommand`), the step to this cycle's goal per
  cycle plus a proportional correction on the measured position, within the model's speed limits;
  the base keeps its own safety (limits, collision detection) and its Cartesian control is reached with
  `eef_control = "native"` (twists, `SendTwistCommand`);
- low level (`low_level = true`): `SetServoingMode(LOW_LEVEL_SERVOING)` and one position per actuator
  per cycle through `BaseCyclic.Refresh(command)`; run it at a high rate (the base expects 1 kHz).

Kinova reports actuator angles in [0, 360) degrees: the driver unwraps continuous joints so their
positions stay continuous, and reports limited joints in (-pi, pi].
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio import clock
from rio.control import twist_between
from rio.interfaces import ArmNode, ModelTable
from rio.interfaces.arm import EEF

from ..description import description
from ..link import KortexConfig, close_session, guarded, hold_faults_and_drops, open_session, watch
from ..models import ARMS, MAX_RATE_HZ, NODE_DEFAULTS, get_arm
from ..pose import from_kinova

MODELS = ModelTable(ARMS, description, default="gen3", defaults=NODE_DEFAULTS, max_rate_hz=MAX_RATE_HZ,
                    ik_extra="rio-kinova[ik]")
_TWO_PI = 2 * math.pi
_GAP_DECAY = 0.98  # per command: a stall's gap is forgotten over a second or two of cycles


def wrap(x):
    """Angles into (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(x, dtype=np.float64), _TWO_PI)


class KinovaArm(ArmNode):
    models = MODELS

    class Config(KortexConfig, ArmNode.Config):
        defaults = MODELS.defaults
        renamed_values = {"eef_control": {"controller": "native"}}
        model: str = MODELS.field()
        low_level: bool = Field(False, description="low-level servoing: positions to the actuators at the cycle "
                                                   "rate, bypassing the base's trajectory control (expert use)")
        gain: float = Field(8.0, ge=0, description="high level: joint speed per rad of tracking error (1/s)")
        eef_control: Literal["ik", "native"] = Field(
            "ik", description='end-effector targets by RIO\'s IK on the arm model ("ik") or the base\'s Cartesian '
                              'twist control ("native", high level only; its tool configuration applies)')
        tcp_offset: tuple[float, float, float, float, float, float] | None = Field(
            None, description="tool centre point from the flange [x, y, z (m), roll, pitch, yaw (rad)] for RIO's model "
                              "(set the same tool on the base in the web app for eef_control = 'native')")

    def setup(self) -> None:
        super().setup()
        self.kinova = get_arm(self.config.model)
        if self.config.low_level and self.config.eef_control == "native":
            raise ValueError("eef_control = 'native' needs the base's high-level control: set low_level = false")
        hold_faults_and_drops(self)
        self._q: np.ndarray | None = None
        self._last: dict[str, Any] = {}  # the last sample read (stands while the session is lost)
        self._frame = 0
        self._t_write: float | None = None  # when the last joint speeds went out
        self._from: np.ndarray | None = None  # the commander's goal before this cycle's step
        self._gap = 0.0  # the recent largest gap between them (s), decaying

    @property
    def streams_poses(self) -> bool:
        return self.config.eef_control == "native"

    # -- hardware -----------------------------------------------------------------------------------
    def open(self) -> None:
        s = open_session(self)
        n = len(s.cyclic.RefreshFeedback().actuators)
        if n != self.kinova.dof:
            self.close()
            raise ValueError(f"the base at {self.config.ip} reports {n} actuators; model '{self.kinova.name}' has "
                             f"{self.kinova.dof}: set model")
        self._last = self.read_joints()

    def close(self) -> None:
        close_session(self)

    def set_enabled(self, enabled: bool) -> None:
        s = self.session
        assert s is not None
        self._t_write, self._gap, self._from = None, 0.0, None  # a pause while disabled is not a slow cycle
        mode = s.pb.Base_pb2.ServoingModeInformation()
        if enabled:
            mode.servoing_mode = (s.pb.Base_pb2.LOW_LEVEL_SERVOING if self.config.low_level
                                  else s.pb.Base_pb2.SINGLE_LEVEL_SERVOING)
            s.base.SetServoingMode(mode)
            self._goal = None
        else:
            if self.config.low_level:  # hand control back to the base, which holds the arm
                mode.servoing_mode = s.pb.Base_pb2.SINGLE_LEVEL_SERVOING
                guarded(self, s.base.SetServoingMode, mode)
            guarded(self, s.base.Stop)

    def read_joints(self) -> dict[str, Any]:
        s = self.session
        assert s is not None
        watch(self)  # a lost session is noticed and reopened here
        fb = guarded(self, s.cyclic.RefreshFeedback) if s.alive else None
        if fb is None:  # no answer: the last reading stands, the sample says the link is down
            return {**self._last, "joint_vel": np.zeros(self.kinova.dof)}
        raw = np.radians([a.position for a in fb.actuators])
        q = wrap(raw)
        if self._q is not None:  # continuous joints: the turn nearest the last reading
            cont = np.array(self.kinova.continuous)
            q = np.where(cont, self._q + wrap(q - self._q), q)
        self._q = q
        sample: dict[str, Any] = {"joint_pos": q, "joint_vel": np.radians([a.velocity for a in fb.actuators])}
        if self.streams_poses:
            b = fb.base
            sample["eef_pose"] = from_kinova([b.tool_pose_x, b.tool_pose_y, b.tool_pose_z, b.tool_pose_theta_x,
                                              b.tool_pose_theta_y, b.tool_pose_theta_z])
        if self.enabled and not self.config.low_level:
            # the base went on at the last joint speeds (or twist) through a late cycle: the goal the commander
            # steps next takes up from where that brought the arm (`follow_measured`) rather than pull it back
            twists = self.mode == EEF and self.poses is not None
            commander = self.poses if twists else self.commander
            commander.follow_measured(sample["eef_pose"] if twists else q, clock.now())
            self._from = commander.goal.copy()  # where this cycle's step starts
        if self.faults.fault is None and self.enabled:
            state = s._name(s.pb.Common_pb2.ArmState, fb.base.active_state)
            if state == "ARMSTATE_IN_FAULT":  # a missed notification: the cyclic feedback says so too
                fault = self.faults.ask()
                if fault is not None:
                    self.faults.report(fault)
        self._last = sample
        return sample

    def write_joints(self, joint_pos: np.ndarray) -> None:
        s = self.session
        assert s is not None and self._q is not None
        if self.config.low_level:
            cmd = s.pb.BaseCyclic_pb2.Command()
            self._frame = (self._frame + 1) & 0xFFFF
            cmd.frame_id = self._frame
            for qi in joint_pos:
                a = cmd.actuators.add()
                a.command_id, a.flags, a.position = self._frame, 1, math.degrees(float(qi)) % 360.0
            guarded(self, s.cyclic.Refresh, cmd)
            return
        gap, gain = self._pace()
        step = joint_pos - self._from if self._from is not None else np.zeros_like(joint_pos)
        vmax = np.array(self.kinova.max_joint_speed)
        speed = np.clip(step / gap + gain * (joint_pos - self._q), -vmax, vmax)
        msg = s.pb.Base_pb2.JointSpeeds()
        for i, v in enumerate(speed):
            js = msg.joint_speeds.add()
            js.joint_identifier, js.value, js.duration = i, math.degrees(float(v)), 0
        guarded(self, s.base.SendJointSpeedsCommand, msg)

    def write_pose(self, eef_pose: np.ndarray) -> None:
        s = self.session
        assert s is not None
        # as write_joints: the goal's step of travel over the cycle gap, and a pull toward the goal; the rotation is
        # pulled only (its step too moved the tool point: 3.8 cm of travel during a 0.3 rad turn in place on the fake)
        gap, gain = self._pace()
        twist = gain * twist_between(self._eef, eef_pose, 1.0)  # the error: travel, and rotation the short way
        if self._from is not None:
            twist[:3] += (eef_pose[:3] - self._from[:3]) / gap
        lin, ang = twist[:3], twist[3:]
        cmd = s.pb.Base_pb2.TwistCommand()
        cmd.reference_frame = s.pb.Base_pb2.CARTESIAN_REFERENCE_FRAME_BASE
        cmd.duration = 0
        t = cmd.twist
        t.linear_x, t.linear_y, t.linear_z = (float(v) for v in lin)
        t.angular_x, t.angular_y, t.angular_z = (math.degrees(float(v)) for v in ang)
        guarded(self, s.base.SendTwistCommand, cmd)

    def _pace(self) -> tuple[float, float]:
        """(the time since the last speed command, the pull gain the recent cycles allow). The base keeps a
        speed until the next command, however late that comes. So a command is this cycle's step of the goal
        as a speed over the time cycles take now (a burst of short cycles after a stall would otherwise turn a
        catch-up step into a dash the base keeps up through the next late cycle), plus a pull toward the goal
        that gives way to slow cycles (one that closes the error in less than two cycle gaps overshoots and
        swings: the Gen3 fake with 0.1-0.4 s stalls ran 0.9 m of tool path for a 0.2 m square)."""
        now = clock.now()
        gap = max(now - self._t_write if self._t_write is not None else 0.0, 1.0 / self.config.rate_hz)
        self._t_write, self._gap = now, max(gap, self._gap * _GAP_DECAY)
        return gap, min(self.config.gain, 0.5 / self._gap)
