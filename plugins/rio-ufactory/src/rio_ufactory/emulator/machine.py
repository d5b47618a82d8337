"""The controller's logic, without sockets: motor enable, state and mode, errors and warnings, what
each motion command does to the joints, and what the reports say.

The rules are the real controller's as seen from the SDK:

- After power-on the motors are disabled and the state is 4 (stopped). `motion_enable(True)` powers
  them; `set_state(0)` starts the arm (state 2 sleeping, 1 while moving). Changing the mode stops the
  arm (state 4) until the next `set_state(0)`.
- Motion commands are executed only in state 1/2 (3 paused keeps the queue) with no error: with an
  error every reply carries the error flag (the SDK returns 1), when the arm is not ready the
  not-ready flag (the SDK returns 9). A command of the wrong mode is answered "invalid" (10).
- A fault (collision C31, joint limit C23, e-stop C1/C2, servo C10..C17) stops the arm where it is
  (state 4). Servo errors and e-stops also cut the motors' power. `clean_error` clears the error (an
  e-stop only once released); then `motion_enable(True)` and `set_state(0)` resume.

All methods expect the caller to hold `lock` (the command handler does, per request; the control
loop does, per tick).
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rio.control import IDENTITY, pose_inv, pose_mul, quat_to_rotvec
from rio.kinematics import IKResult, IKSolver

from ..pose import from_xarm, to_xarm
from .codes import (
    ESTOPS,
    FB_DISCARD,
    FB_FAILURE,
    FB_SUCCESS,
    POWER_CUT,
    Err,
    Mode,
    State,
)
from .motion import MotionModel, Segment
from .protocol import STATUS_ERROR, STATUS_NOT_READY, STATUS_WARN
from .tool import ToolBoard

#: The SDK lets joint targets pass up to this much beyond a limit (rad); so does the controller.
LIMIT_TOLERANCE = math.radians(0.1)
#: How close inverse kinematics gets (m, rad) before it stops iterating ...
IK_POS_TOL, IK_ROT_TOL = 1e-5, 1e-4
#: ... and how far off a pose may stay to count as reached (farther: "no inverse kinematics solution").
REACH_POS_TOL, REACH_ROT_TOL = 1e-3, 3e-3


class Refused(Exception):
    """The command is invalid here (wrong mode, unreachable pose): the reply's invalid flag."""


@dataclass
class Snapshot:
    """The controller as the reports describe it, taken once per control tick."""

    t: float
    state: int
    mode: int
    cmdnum: int
    q: np.ndarray  # 7 joints (rad), zeros past the arm's axis count
    qd: np.ndarray
    torque: np.ndarray
    pose: np.ndarray  # x, y, z (mm), roll, pitch, yaw (rad)
    rotvec: np.ndarray
    tcp_speed: float
    mtbrake: int
    mtable: int
    error: int
    warn: int
    tcp_offset: np.ndarray
    tcp_load: np.ndarray
    collision_sens: int
    teach_sens: int
    gravity: np.ndarray
    device_type: int
    axis: int
    version: str
    limits: np.ndarray  # 14: min, max per joint
    world_offset: np.ndarray
    simulation_robot: bool
    counter: int
    servo_codes: bytes = field(default=bytes(16))


def _pad7(v) -> np.ndarray:
    out = np.zeros(7)
    v = np.asarray(v, dtype=float)[:7]
    out[: len(v)] = v
    return out


class ArmMachine:
    """`kinematics`: core's IK solver of the arm's flange (`rio.kinematics`, the site `tcp` of the model's
    robot description), used under `lock` only; None runs joint-space only (poses read 0, Cartesian
    commands are refused)."""

    def __init__(self, arm, joints, tool: ToolBoard, kinematics: IKSolver | None = None, sn: str = "",
                 box_sn: str = "", firmware: str = "2.6.0"):
        self.lock = threading.RLock()
        self.arm = arm
        self.axis = arm.axis
        self.limits = np.array(arm.limits, dtype=float)
        self._limits14 = np.zeros(14)  # as the rich report lists them: min, max per joint
        self._limits14[: 2 * self.axis] = self.limits.reshape(-1)
        self.motion = MotionModel(joints, arm.max_joint_speed)
        self.tool = tool
        self.kin = kinematics
        self.sn, self.box_sn, self.firmware = sn, box_sn, firmware
        self.version = f"{arm.axis},{arm.device_type},{sn},{box_sn},v{firmware}"
        self.state = State.STOPPED
        self.mode = Mode.POSITION
        self.error_code = 0
        self.warn_code = 0
        self.enabled = False
        self.estop_pressed = False
        self.servo_codes = bytearray(16)
        # parameters the SDK sets and the reports echo
        self.tcp_offset = np.zeros(6)
        self.tcp_load = np.zeros(4)
        self.collision_sens = 3
        self.teach_sens = 3
        self.gravity = np.array([0.0, 0.0, -1.0])
        self.world_offset = np.zeros(6)
        self.simulation_robot = False
        self.counter = 0
        self.params: dict[str, Any] = {}  # everything else set and read back (jerk, reduced mode, ...)
        # for tests
        self.servo_commands = 0
        self.last_servo_target: np.ndarray | None = None
        self.last_command_time: float | None = None
        self._events: list[tuple[Any, int, int]] = []
        self._pose_cache: tuple[float, np.ndarray] | None = None
        self.snapshot = self.take_snapshot(time.monotonic())

    # -- condition ---------------------------------------------------------------------------------
    @property
    def ready(self) -> bool:
        return self.enabled and self.state in (State.MOVING, State.SLEEPING, State.PAUSED)

    def status_byte(self) -> int:
        s = 0
        if self.error_code:
            s |= STATUS_ERROR
        if self.warn_code:
            s |= STATUS_WARN
        if not self.ready:
            s |= STATUS_NOT_READY
        return s

    def can_move(self, mode: Mode | None = None) -> bool:
        """True when a motion command may run now; raises Refused for a command of another mode."""
        if self.error_code or not self.ready:
            return False
        if mode is not None and self.mode != mode:
            raise Refused(f"needs mode {int(mode)}, the arm is in mode {int(self.mode)}")
        return True

    # -- the controller's state machine ---------------------------------------------------------------
    def motion_enable(self, servo_id: int, on: bool) -> None:
        if on:
            if self.error_code:
                return  # the error must be cleared first
            self.enabled = True  # one joint or all: the emulated arm powers all of them together
        else:
            self.enabled = False
            self._halt(FB_FAILURE)
            self.state = State.STOPPED

    def set_state(self, state: int) -> None:
        if state == State.START:
            if self.error_code or not self.enabled:
                return
            if self.state == State.STOPPED:
                self.motion.servo_target = self.motion.q_cmd.copy()  # no jump to an old target
            self.state = State.SLEEPING
        elif state == State.PAUSED:
            if self.state in (State.MOVING, State.SLEEPING):
                self.state = State.PAUSED
        elif state in (State.STOPPED, 6):  # 6: decelerate and stop
            self._halt(FB_DISCARD)
            self.state = State.STOPPED

    def set_mode(self, mode: int) -> None:
        self.mode = Mode(mode) if mode in Mode._value2member_map_ else mode
        if self.state != State.STOPPED:
            self._halt(FB_DISCARD)
            self.state = State.STOPPED

    def fault(self, code: int) -> None:
        self.error_code = int(code)
        self._halt(FB_FAILURE)
        self.state = State.STOPPED
        if code in POWER_CUT:
            self.enabled = False

    def clean_error(self) -> None:
        if self.error_code in ESTOPS and self.estop_pressed:
            return
        self.error_code = 0
        self.servo_codes[:] = bytes(16)

    def _halt(self, code: int) -> None:
        """Stop where the joints are; every queued command ends (the interrupted one with `code`)."""
        for i, seg in enumerate(self.motion.stop()):
            if seg.tag is not None and seg.end_kind:
                self._events.append((seg.tag, seg.end_kind, code if i == 0 else FB_DISCARD))

    # -- motion commands ----------------------------------------------------------------------------
    def _check_limits(self, q: np.ndarray) -> bool:
        finite = np.isfinite(q)
        lo, hi = self.limits[:, 0] - LIMIT_TOLERANCE, self.limits[:, 1] + LIMIT_TOLERANCE
        if np.any(finite & ((q < lo) | (q > hi))):
            self.fault(Err.JOINT_LIMIT)
            return False
        return True

    def servo_joints(self, q7) -> None:
        q = np.asarray(q7, dtype=float)[: self.axis]
        self.servo_commands += 1
        self.last_servo_target = q.copy()
        self.last_command_time = time.monotonic()
        if not self.can_move(Mode.SERVO) or not self._check_limits(q):
            return
        self.motion.servo(np.where(np.isfinite(q), q, self.motion.servo_target), self.last_command_time)

    def servo_cartesian(self, pose6, tool_coord: bool = False) -> None:
        self.last_command_time = time.monotonic()
        if not self.can_move(Mode.SERVO):
            return
        goal = from_xarm(pose6)
        if tool_coord:
            goal = pose_mul(self.tcp_frame(self.motion.servo_target), goal)
        self.motion.servo(self._solve(goal, self.motion.servo_target, iterations=6).q, self.last_command_time)

    def move_joints(self, q7, speed: float, acc: float, tag=None, kinds=(0, 0)) -> None:
        q = np.asarray(q7, dtype=float)[: self.axis]
        q = np.where(np.isfinite(q), q, np.nan)
        if not self.can_move(Mode.POSITION) or not self._check_limits(np.nan_to_num(q, nan=0.0)):
            return
        self._enqueue(Segment(goal=q, speed=min(max(speed, 1e-4), self.arm.max_joint_speed), acc=max(acc, 0.01),
                              start_kind=kinds[0], end_kind=kinds[1], tag=tag))

    def move_line(self, pose6, speed_mm: float, acc_mm: float, tool_coord: bool = False, axis_angle: bool = False,
                  tag=None, kinds=(0, 0)) -> None:
        if not self.can_move(Mode.POSITION):
            return
        start_q = self._queue_end()
        start = self.tcp_frame(start_q)
        pose = np.asarray(pose6, dtype=float)
        if not tool_coord:  # unspecified coordinates (inf) keep the present ones
            pose = np.where(np.isfinite(pose), pose, to_xarm(start, axis_angle=axis_angle))
        goal = from_xarm(pose, axis_angle=axis_angle)
        if tool_coord:
            goal = pose_mul(start, goal)
        q = self._reach(goal, start_q, iterations=60)
        dist = float(np.linalg.norm(goal[:3] - start[:3])) * 1000.0
        duration = max(dist / max(speed_mm, 0.1), 0.05)
        joint_speed = float(np.abs(q - start_q).max()) / duration
        self.move_joints(q, max(joint_speed, 1e-3), 20.0, tag, kinds)

    def pause_for(self, seconds: float, tag=None, kinds=(0, 0)) -> None:
        self._enqueue(Segment(duration=max(float(seconds), 0.0), start_kind=kinds[0], end_kind=kinds[1], tag=tag))

    def marker(self, tag, end_kind: int, on_reach=None) -> None:
        """Something to signal (or do) when the motion queue gets here (now if it is empty)."""
        self._enqueue(Segment(end_kind=end_kind, tag=tag, on_reach=on_reach))

    def _enqueue(self, seg: Segment) -> None:
        self.motion.enqueue(seg)

    def _queue_end(self) -> np.ndarray:
        """Where the joints will be once the queue is done (where IK of a queued move starts)."""
        q = self.motion.q_cmd.copy()
        for seg in ([self.motion.active] if self.motion.active else []) + list(self.motion.queue):
            if seg.goal is not None:
                q = np.where(np.isfinite(seg.goal), seg.goal, q)
        return q

    # -- kinematics --------------------------------------------------------------------------------
    def tcp_frame(self, q) -> np.ndarray:
        """The TCP (flange and tool offset) pose at joints `q`: `[x, y, z (m), qw, qx, qy, qz]`."""
        if self.kin is None:
            return IDENTITY.copy()
        return pose_mul(self.kin.fk(np.asarray(q, dtype=float)[: self.axis]), from_xarm(self.tcp_offset))

    def _solve(self, tcp_goal: np.ndarray, q0, iterations: int) -> IKResult:
        """Joints near `q0` putting the TCP at `tcp_goal` (a 7-vector pose); the best effort when out of
        reach. Joint limits hold (they are the model's)."""
        if self.kin is None:
            raise Refused("no kinematic model for this arm (its MJCF, or mujoco and mink: pip install "
                          "'rio-ufactory[ik]')")
        flange_goal = pose_mul(tcp_goal, pose_inv(from_xarm(self.tcp_offset)))
        return self.kin.solve(flange_goal, np.asarray(q0, dtype=float)[: self.axis], pos_tol=IK_POS_TOL,
                              rot_tol=IK_ROT_TOL, max_iters=iterations)

    def _reach(self, tcp_goal: np.ndarray, q0, iterations: int) -> np.ndarray:
        """The joints of `_solve`, or Refused when they leave the TCP farther off than the controller would."""
        r = self._solve(tcp_goal, q0, iterations)
        if r.pos_err > REACH_POS_TOL or r.rot_err > REACH_ROT_TOL:
            raise Refused(f"no inverse kinematics solution for that pose ({r.pos_err * 1000:.1f} mm, "
                          f"{r.rot_err:.3f} rad off)")
        return r.q

    def inverse_kinematics(self, pose6, q_ref=None) -> np.ndarray:
        """get_ik: joints (rad) for a TCP pose [x, y, z (mm), roll, pitch, yaw], near `q_ref` (default: now)."""
        return self._reach(from_xarm(pose6), self.motion.q if q_ref is None else q_ref, iterations=200)

    # -- the control tick ------------------------------------------------------------------------------
    def tick(self, now: float, dt: float) -> list[tuple[Any, int, int]]:
        """One control period: move, settle the state, refresh the snapshot. Returns the feedback
        events due: (tag, kind, code)."""
        run = self.state in (State.MOVING, State.SLEEPING) and self.enabled and not self.error_code
        for what, seg in self.motion.step(now, dt, run, servo_mode=self.mode == Mode.SERVO):
            if what == "start" and seg.start_kind and seg.tag is not None:
                self._events.append((seg.tag, seg.start_kind, FB_SUCCESS))
            elif what == "end":
                if seg.on_reach is not None:
                    seg.on_reach()
                if seg.end_kind and seg.tag is not None:
                    self._events.append((seg.tag, seg.end_kind, FB_SUCCESS))
        if self.state in (State.MOVING, State.SLEEPING):
            self.state = State.MOVING if self.motion.moving(self.mode == Mode.SERVO) else State.SLEEPING
        self.tool.update()
        self.snapshot = self.take_snapshot(now)
        events, self._events = self._events, []
        return events

    def take_snapshot(self, now: float) -> Snapshot:
        q = self.motion.q
        tcp = self.tcp_frame(q)
        pose, rotvec = np.zeros(6), np.zeros(3)
        if self.kin is not None:
            pose, rotvec = np.array(to_xarm(tcp)), quat_to_rotvec(tcp[3:])
        speed = 0.0
        if self._pose_cache is not None and self.kin is not None:
            t0, p0 = self._pose_cache
            if now > t0:
                speed = float(np.linalg.norm(tcp[:3] - p0)) * 1000.0 / (now - t0)
        self._pose_cache = (now, tcp[:3]) if self.kin is not None else None
        mask = (1 << self.axis) - 1 if self.enabled else 0
        return Snapshot(
            t=now, state=int(self.state), mode=int(self.mode), cmdnum=self.motion.pending, q=_pad7(q),
            qd=_pad7(self.motion.qd), torque=np.zeros(7), pose=pose,
            rotvec=rotvec, tcp_speed=speed,
            mtbrake=mask, mtable=mask, error=self.error_code, warn=self.warn_code,
            tcp_offset=self.tcp_offset.copy(), tcp_load=self.tcp_load.copy(),
            collision_sens=self.collision_sens, teach_sens=self.teach_sens, gravity=self.gravity.copy(),
            device_type=self.arm.device_type, axis=self.axis, version=self.version,
            limits=self._limits14,
            world_offset=self.world_offset.copy(), simulation_robot=self.simulation_robot,
            counter=self.counter, servo_codes=bytes(self.servo_codes))

