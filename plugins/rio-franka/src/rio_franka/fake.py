"""A stand-in for franky's `Robot` and `Gripper` objects, for tests and robot-free stations.

libfranka talks to the robot over a 1 kHz UDP protocol with hard real-time deadlines and a
proprietary server side: emulating it would test an emulator, not the driver. So the seam is one
level up: the driver gets its robot and gripper objects from `backend.py`, and with `backend = "fake"`
(or `"sim"`) these objects take franky's own motion objects (`JointMotion`, `CartesianMotion`), report
franky-shaped states and raise franky's own exception types with libfranka's messages. What is real:
franky's types and messages, the driver. What is faked: the control box (its motion generator, reflexes
and link), modelled as:

- an asynchronous motion replaces the running one and is followed with per-joint speed (Franka's
  published limits x relative_dynamics_factor) and acceleration limits, like franky's Ruckig-planned
  motions; Cartesian targets are solved to joints by RIO's IK on the same model;
- `inject(...)` raises a reflex (joint, Cartesian, collision, communication, power), a user stop or a
  dropped link: the motion is aborted, the arm holds, `state.current_errors` lists libfranka's flags
  and the next `move()` raises `ControlException` until `recover_from_errors()`;
- with a rio-sim world (`backend = "sim"` / `"sim:ARM@WORLD"`) the motion generator's joint targets
  drive the world's arm through `WorldArm` and the joints and fingers are read back from physics.

One `FakeController` per IP, shared by the robot and gripper objects (as one control box serves both),
so a test finds it with `controller(ip)` to inject faults.
"""

from __future__ import annotations

import math
import threading
from types import SimpleNamespace
from typing import Any

import numpy as np

from rio import clock

from .faults import ERROR_FLAGS
from .models import ArmModel, get_arm

MAX_ACCEL = 10.0  # rad/s^2 at relative_dynamics_factor 1 (the FR3's joint acceleration limits are 10-20)
LIBRARY_VERSION = 9  # the FCI protocol version the fake's "libfranka" speaks

_REFLEX_FLAGS = {
    "joint_reflex": ["joint_reflex"], "cartesian_reflex": ["cartesian_reflex"],
    "collision": ["joint_reflex", "cartesian_reflex"], "communication": ["communication_constraints_violation"],
    "power": ["power_limit_violation"]}


def _franky():
    import franky

    return franky


class _Errors:
    """franky's `Errors`: one bool per libfranka flag."""

    def __init__(self, flags=()):
        for f in ERROR_FLAGS:
            setattr(self, f, f in flags)

    def __str__(self) -> str:
        return "[" + ", ".join(f'"{f}"' for f in ERROR_FLAGS if getattr(self, f)) + "]"


class FakeController:
    """The fake control box behind one IP: the arm's motion generator, the hand, faults and link."""

    def __init__(self, ip: str, model: ArmModel, world: tuple[str, str] | None = None):
        self.ip, self.model = ip, model
        self.lock = threading.RLock()
        self.server_version = LIBRARY_VERSION  # set another to get libfranka's version mismatch on connect
        self.fci_active = True  # False: the connection is refused as when FCI is not activated in Desk
        self.link_up = True
        self.relative_dynamics_factor = 1.0
        self.flags: list[str] = []
        self.collided = False
        self.mode_name = "Idle"
        self.motions = 0  # motions received (each async move replaces the last)
        self.world = None
        if world is not None:
            from rio_sim.world_arm import WorldArm

            self.world = WorldArm.attach(world[1], world[0])
        self.q = np.array(self.world.joint_pos() if self.world else model.home, dtype=np.float64)
        self.q_d, self.dq = self.q.copy(), np.zeros(7)
        self.target: np.ndarray | None = None
        self._ik_seed = self.q.copy()
        self._t = clock.now()
        self._kin: Any = None
        # the hand
        self.width = 0.08 if self.world is None else self.world.finger_width()
        self.width_goal, self.width_speed, self.width_d = self.width, 0.1, self.width
        # With a world and each node in its own process (shm), the arm's and the hand's nodes each have a
        # box of their own on one simulated robot: a box drives the world's joints only once it was sent
        # an arm motion, and its fingers only once it was sent a hand command, so neither holds the other.
        self.steers_arm = self.steers_hand = world is None
        self.grasping: tuple[float, float, float] | None = None  # (width, eps_inner, eps_outer)
        self.object_width: float | None = None  # model mode: an object between the fingers stops a grasp
        self.gripper_link_up = True
        self.width_rate = 0.0  # m/s, measured (physics)

    # -- time ------------------------------------------------------------------------------------
    def advance(self) -> None:
        with self.lock:
            now = clock.now()
            gap, self._t = now - self._t, now
            if gap <= 0:
                return
            n = min(max(1, math.ceil(gap / 0.002)), 500)
            dt = gap / n
            vmax = np.asarray(self.model.max_joint_speed) * self.relative_dynamics_factor
            amax = MAX_ACCEL * self.relative_dynamics_factor
            goal = self.q_d if self.target is None else self.target
            for _ in range(n):
                e = goal - self.q_d
                v_des = np.sign(e) * np.minimum(np.minimum(vmax, np.sqrt(2 * amax * np.abs(e))), np.abs(e) / dt)
                self.dq += np.clip(v_des - self.dq, -amax * dt, amax * dt)
                self.q_d = self.q_d + self.dq * dt
            self._advance_hand(gap)
            if self.world is not None:
                if self.steers_arm:
                    self.world.command_joints(self.q_d, now + 0.01)
                else:  # another process's box drives the arm: follow what physics does
                    self.q_d = self.world.joint_pos()
                self.q = self.world.joint_pos()
            else:
                self.q = self.q_d.copy()

    def _advance_hand(self, gap: float) -> None:
        """The hand's own motion: the finger goal moves at `speed` toward the last command (as the
        Franka Hand does, however often commands arrive); physics or the model follows it."""
        goal = self.width_goal
        if self.world is None and self.grasping is not None and self.object_width is not None:
            goal = max(goal, self.object_width)
        step = self.width_speed * gap
        self.width_d += float(np.clip(goal - self.width_d, -step, step))
        if self.world is None:
            self.width = self.width_d
            return
        if self.steers_hand:
            self.world.command_width(self.width_d, clock.now() + 0.01)
        width = self.world.finger_width()
        if gap > 0.005:  # a rate over a real interval, not two reads in one cycle
            self.width_rate = (width - self.width) / gap
        self.width = width

    # -- the arm ---------------------------------------------------------------------------------
    def kinematics(self):
        if self._kin is None:
            from rio.kinematics import solver_from_description

            from .description import description

            try:
                self._kin = solver_from_description(description(self.model.name), orientation_cost=1.0,
                                                    damping=1e-4)
            except ImportError as e:
                cause = e.__cause__ if isinstance(e.__cause__, ImportError) else e
                raise ImportError(f"the fake Franka robot moves and measures its flange by IK on the arm model, "
                                  f"which needs its solver ({cause}): pip install 'rio-franka[ik]'") from None
        return self._kin

    def flange_pose(self) -> np.ndarray:
        return self.kinematics().fk(self.q)

    def move(self, motion) -> None:
        f = _franky()
        with self.lock:
            self.advance()
            if self.flags or self.mode_name == "User stopped":
                if self.mode_name == "User stopped":
                    raise f.CommandException('libfranka: Move command rejected: command not possible in the current '
                                             'mode ("User stopped")!')
                raise f.ControlException(f"libfranka: Move command aborted: motion aborted by reflex! "
                                         f"{_Errors(self.flags)}\ncontrol_command_success_rate: 0.99")
            target = motion.target
            if isinstance(motion, f.JointMotion):
                q = np.asarray(target.position, dtype=np.float64)
            elif isinstance(motion, f.CartesianMotion):
                pose = getattr(target, "end_effector_pose", None)
                pose = target.pose.end_effector_pose if pose is None else pose
                from rio.control import matrix_to_pose

                sol = self.kinematics().solve(matrix_to_pose(np.asarray(pose.matrix)), self._ik_seed, max_iters=30)
                q = self._ik_seed = np.asarray(sol.q, dtype=np.float64)
            else:
                raise f.InvalidMotionTypeException(f"the fake robot follows JointMotion and CartesianMotion, "
                                                   f"not {type(motion).__name__}")
            lo, hi = np.array(self.model.limits).T
            if np.any(q < lo - 1e-6) or np.any(q > hi + 1e-6):
                self._reflex(["joint_motion_generator_position_limits_violation"])
                raise f.ControlException('libfranka: Move command aborted: motion aborted by reflex! '
                                         '["joint_motion_generator_position_limits_violation"]')
            self.target = q
            self.mode_name = "Move"
            self.motions += 1
            self.steers_arm = True

    def hold(self) -> None:
        with self.lock:
            self.advance()
            self.target, self.dq = None, np.zeros(7)
            if not self.flags:
                self.mode_name = "Idle"

    def _reflex(self, flags: list[str]) -> None:
        self.flags, self.target, self.dq = list(flags), None, np.zeros(7)
        self.mode_name = "Reflex"

    # -- fault injection -------------------------------------------------------------------------
    def inject(self, what: str) -> None:
        """'joint_reflex' | 'cartesian_reflex' | 'collision' | 'communication' | 'power': a reflex as
        libfranka reports it; 'user_stopped': the enabling device released; 'link_lost': no more state
        (every call raises franky's NetworkException until `restore_link()`)."""
        with self.lock:
            self.advance()
            if what == "link_lost":
                self.link_up = self.gripper_link_up = False
            elif what == "user_stopped":
                self.target, self.dq, self.mode_name = None, np.zeros(7), "User stopped"
            else:
                self._reflex(_REFLEX_FLAGS[what])
                self.collided = what == "collision"

    def restore_link(self) -> None:
        with self.lock:
            self.link_up = self.gripper_link_up = True

    def recover(self) -> bool:
        with self.lock:
            self.flags, self.collided, self.mode_name = [], False, "Idle"
            return True

    def state(self) -> SimpleNamespace:
        f = _franky()
        with self.lock:
            self.advance()
            flange = self.flange_pose()
            ee = f.Affine(flange[:3], _xyzw(flange[3:]))
            coll = [1.0 if self.collided else 0.0]
            return SimpleNamespace(
                q=self.q.copy(), dq=self.dq.copy() if self.world is None else self.world.joint_vel(),
                q_d=self.q_d.copy(), O_T_EE=ee, F_T_EE=f.Affine(), robot_mode=self.mode_name,
                current_errors=_Errors(self.flags), last_motion_errors=_Errors(self.flags),
                joint_collision=coll * 7, cartesian_collision=coll * 6, time=clock.now())

    def close(self) -> None:
        if self.world is not None:
            self.world.close()
            self.world = None

    def serves(self, world: tuple[str, str] | None) -> bool:
        """Whether this box can serve a station asking for `world`: the same kind, and its world running."""
        if world is None or self.world is None:
            return world is None and self.world is None
        try:
            self.world.check_alive()
        except Exception:
            return False
        return (self.world.arm, self.world.world) == tuple(world)  # (arm, world), as controller() takes it


def _xyzw(wxyz) -> list[float]:
    return [float(wxyz[1]), float(wxyz[2]), float(wxyz[3]), float(wxyz[0])]


class FakeRobot:
    """franky.Robot's surface the driver uses, on a `FakeController`."""

    def __init__(self, ctl: FakeController, relative_dynamics_factor: float = 1.0):
        f = _franky()
        if not ctl.fci_active:
            raise f.NetworkException("libfranka: Connection to FCI refused. Please install FCI feature or enable "
                                     "FCI mode in Desk.")
        if not ctl.link_up:
            raise f.NetworkException("libfranka: Connection timeout")
        if ctl.server_version != LIBRARY_VERSION:
            raise f.IncompatibleVersionException(
                f"libfranka: Incompatible library version (server version: {ctl.server_version}, library version: "
                f"{LIBRARY_VERSION}). Please check https://frankarobotics.github.io for compatibility updates.")
        self.ctl, self.dead = ctl, False
        ctl.relative_dynamics_factor = float(relative_dynamics_factor)
        self.impedance: dict[str, Any] = {}

    def _link(self) -> FakeController:
        if self.dead or not self.ctl.link_up:
            self.dead = True  # as libfranka's Robot: unusable after a network error, connect again
            raise _franky().NetworkException("libfranka: UDP receive: Timeout")
        return self.ctl

    # state
    @property
    def state(self):
        return self._link().state()

    @property
    def current_joint_state(self):
        s = self.state
        return _franky().JointState(s.q, s.dq)

    @property
    def has_errors(self) -> bool:
        return bool(self._link().flags)

    @property
    def relative_dynamics_factor(self) -> float:
        return self.ctl.relative_dynamics_factor

    @relative_dynamics_factor.setter
    def relative_dynamics_factor(self, value) -> None:
        self.ctl.relative_dynamics_factor = float(value)

    # commands
    def move(self, motion, asynchronous: bool = False) -> None:
        self._link().move(motion)

    def stop(self) -> None:
        self._link().hold()

    def join_motion(self, timeout=None) -> None:
        self._link().advance()

    def recover_from_errors(self) -> bool:
        return self._link().recover()

    def set_collision_behavior(self, torque_thresholds, force_thresholds) -> None:
        self._link()
        self.impedance["collision"] = (torque_thresholds, force_thresholds)

    def set_joint_impedance(self, k) -> None:
        self._link()
        self.impedance["joint"] = list(k)

    def set_cartesian_impedance(self, k) -> None:
        self._link()
        self.impedance["cartesian"] = list(k)


class FakeGripper:
    """franky.Gripper's surface (asynchronous move and grasp, width, is_grasped), on a `FakeController`."""

    max_width = 0.08

    def __init__(self, ctl: FakeController):
        if not ctl.gripper_link_up:
            raise _franky().NetworkException("libfranka gripper: Connection timeout")
        self.ctl = ctl

    def _link(self) -> FakeController:
        if not self.ctl.gripper_link_up:
            raise _franky().NetworkException("libfranka gripper: UDP receive: Timeout")
        self.ctl.advance()
        return self.ctl

    @property
    def width(self) -> float:
        return float(self._link().width)

    @property
    def state(self) -> SimpleNamespace:
        """franky.GripperState: one reading of width and is_grasped together."""
        c = self._link()
        with c.lock:
            return SimpleNamespace(width=float(c.width), is_grasped=self._grasped(c), max_width=self.max_width,
                                   temperature=30, time=clock.now())

    @property
    def is_grasped(self) -> bool:
        return self._grasped(self._link())

    def _grasped(self, c: FakeController) -> bool:
        if c.grasping is None:
            return False
        w, inner, outer = c.grasping
        settled = abs(c.width - c.width_goal) < 1e-4 or (c.world is None and c.object_width is not None
                                                          and abs(c.width - max(c.width_goal, c.object_width)) < 1e-4)
        if c.world is not None:  # physics: the fingers stopped on something short of the goal
            settled = c.width > c.width_goal + 0.002 and abs(c.width_rate) < 0.005
        return settled and (w - inner) < c.width < (w + outer)

    def _command(self, width: float, speed: float, grasp: tuple[float, float, float] | None) -> None:
        c = self._link()
        with c.lock:
            c.width_goal, c.width_speed, c.grasping = float(np.clip(width, 0.0, self.max_width)), float(speed), grasp
            c.steers_hand = True

    def move_async(self, width: float, speed: float):
        self._command(width, speed, None)
        return True

    def grasp_async(self, width: float, speed: float, force: float, epsilon_inner: float = 0.005,
                    epsilon_outer: float = 0.005):
        self._command(width, speed, (float(width), float(epsilon_inner), float(epsilon_outer)))
        return True

    def stop(self) -> bool:
        c = self._link()
        c.width_goal = c.width
        return True


_CONTROLLERS: dict[str, FakeController] = {}
_LOCK = threading.Lock()


def controller(ip: str, model: str | None = None, world: tuple[str, str] | None = None) -> FakeController:
    """The fake control box at `ip` (made on first use; `world` = (arm, world) for a rio-sim one). The
    arm's node names the model; a gripper node that comes first makes an FR3 box the arm then renames."""
    with _LOCK:
        ctl = _CONTROLLERS.get(ip)
        if ctl is not None and not ctl.serves(world):  # a box left by an earlier station whose world is gone
            ctl.close()
            ctl = None
        if ctl is None:
            ctl = _CONTROLLERS[ip] = FakeController(ip, get_arm(model or "fr3"), world)
        elif model is not None and ctl.model.name != model:
            ctl.model = get_arm(model)  # same kinematics, other limits and speeds
            ctl._kin = None
        return ctl


def forget(ip: str) -> None:
    """Drop the fake control box at `ip` (its world link closed)."""
    with _LOCK:
        ctl = _CONTROLLERS.pop(ip, None)
    if ctl is not None:
        ctl.close()
