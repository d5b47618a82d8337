"""The emulated UR controller's state, one 500 Hz control tick at a time: robot mode (power, brakes),
safety mode (protective stop, emergency stop, ...), speed slider, program state, and the joints.

Servo behaviour (what servoJ does on the controller, as far as a driver can tell): each servo command
replaces the target; the setpoint follows it through a first-order filter whose time constant is the
command's `lookahead_time` (UR's smoothing), at most at the joints' rated speed times the speed
slider. The setpoint is moved by the time since it last moved, up to when each command arrived (the
target it replaces until then), not by control ticks: a tick after the emulator's thread was
descheduled moved the whole stall (up to 50 ms) toward a target that came at its end, faster than
the rated speed allows. The joints are the setpoint (model backend: a 4 ms lag) or a rio-sim arm's
(`SimJoints`).
Nothing moves unless the robot is RUNNING (powered, brakes released) in safety mode NORMAL and a
control client is connected. Faults are injected by tests (`protective_stop()`, `emergency_stop()`) and
cleared the way a person would: the dashboard's "unlock protective stop", releasing the e-stop and
powering on again.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Sequence

import numpy as np

from rio.control import pose_mul, quat_to_rotvec, rotvec_to_quat

from ..kinematics import flange_pose
from ..models import URModel

# Robot modes and safety modes, as the controller numbers them (RTDE `robot_mode`, `safety_mode`).
POWER_OFF, POWER_ON, IDLE, RUNNING = 3, 4, 5, 7
ROBOT_MODES = {-1: "NO_CONTROLLER", 0: "DISCONNECTED", 1: "CONFIRM_SAFETY", 2: "BOOTING", 3: "POWER_OFF",
               4: "POWER_ON", 5: "IDLE", 6: "BACKDRIVE", 7: "RUNNING", 8: "UPDATING_FIRMWARE"}
NORMAL, REDUCED, PROTECTIVE_STOP, SAFEGUARD_STOP, ROBOT_EMERGENCY_STOP, VIOLATION, FAULT = 1, 2, 3, 5, 7, 8, 9
SAFETY_MODES = {1: "NORMAL", 2: "REDUCED", 3: "PROTECTIVE_STOP", 4: "RECOVERY", 5: "SAFEGUARD_STOP",
                6: "SYSTEM_EMERGENCY_STOP", 7: "ROBOT_EMERGENCY_STOP", 8: "VIOLATION", 9: "FAULT"}
#: RTDE `safety_status_bits` bit of each safety mode.
_SAFETY_BIT = {1: 0, 2: 1, 3: 2, 4: 3, 5: 4, 6: 5, 7: 6, 8: 8, 9: 9}
#: RTDE `runtime_state`.
STOPPED, PLAYING = 1, 2
RATE_HZ = 500.0


class ModelJoints:
    def __init__(self, q0: Sequence[float], lag: float = 0.004):
        self.q = np.asarray(q0, dtype=float).copy()
        self.lag = lag

    def read(self) -> np.ndarray:
        return self.q.copy()

    def write(self, q_cmd: np.ndarray, dt: float) -> None:
        self.q += (q_cmd - self.q) * (1.0 - math.exp(-dt / self.lag))

    def close(self) -> None:
        pass


class URRobot:
    def __init__(self, model: URModel, joints=None, q0: Sequence[float] | None = None):
        self.model = model
        self.joints = joints if joints is not None else ModelJoints(model.home if q0 is None else q0)
        self.lock = threading.RLock()
        self.q = self.joints.read()
        self.qd = np.zeros(6)
        self.q_cmd = self.q.copy()
        self.target = self.q.copy()
        self.lookahead = 0.1
        self.t_followed: float | None = None  # the time the setpoint has followed the target up to
        self.robot_mode, self.safety_mode = RUNNING, NORMAL
        self.speed_slider = 1.0
        self.remote_control = True
        self.program: str | None = None
        self.program_playing = False
        self.control_clients = 0  # the stand-in control script: running while a client holds the servo port
        self.tcp_offset = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
        self.servo_commands = 0
        self.t0 = time.monotonic()
        self.ticks = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    # -- life -----------------------------------------------------------------------------------------
    def start(self) -> URRobot:
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="ur-emulator-tick", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2.0)
        self.joints.close()

    def _run(self) -> None:
        period, t_next, t_last = 1.0 / RATE_HZ, time.monotonic(), time.monotonic()
        while not self._stop.is_set():
            now = time.monotonic()
            self.tick(min(now - t_last, 0.05), now)
            t_last = now
            t_next += period
            delay = t_next - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            elif delay < -0.1:
                t_next = time.monotonic()

    def tick(self, dt: float, now: float | None = None) -> None:
        """One control tick at `now` (monotonic s; None: now): the setpoint follows the target for the
        time since it last did, the joints follow the setpoint for `dt`."""
        with self.lock:
            self._follow(time.monotonic() if now is None else now)
            self.joints.write(self.q_cmd, dt)
            q = self.joints.read()
            if dt > 0:
                self.qd = (q - self.q) / dt
            self.q = q
            self.ticks += 1

    # -- what the RTDE stream reports -----------------------------------------------------------------
    @property
    def can_move(self) -> bool:
        return self.robot_mode == RUNNING and self.safety_mode == NORMAL and self.control_clients > 0

    @property
    def running(self) -> bool:
        return self.control_clients > 0 or self.program_playing

    def tcp_pose(self) -> np.ndarray:
        """UR format: [x, y, z (m), rx, ry, rz (rotation vector)] of the TCP in the base frame."""
        p = pose_mul(flange_pose(self.model, self.q), self.tcp_offset)
        return np.concatenate([p[:3], quat_to_rotvec(p[3:])])

    def safety_status_bits(self) -> int:
        return 1 << _SAFETY_BIT.get(self.safety_mode, 0)

    def robot_status_bits(self) -> int:
        return (self.robot_mode >= POWER_ON) | (self.running << 1)

    # -- the control script's stand-in (servo port) ---------------------------------------------------
    def _follow(self, t: float) -> None:
        """The setpoint toward the target (lookahead filter, rated speed) from when it last moved to `t`."""
        elapsed = 0.0 if self.t_followed is None else t - self.t_followed
        if elapsed <= 0:
            self.t_followed = t if self.t_followed is None else self.t_followed
            return
        self.t_followed = t
        if self.can_move:
            alpha = 1.0 - math.exp(-elapsed / max(self.lookahead, 1e-3))
            step = np.asarray(self.model.max_speed) * self.speed_slider * elapsed
            self.q_cmd = self.q_cmd + np.clip((self.target - self.q_cmd) * alpha, -step, step)

    def servo_j(self, q: Sequence[float], lookahead: float, t: float | None = None) -> bool:
        """A servo command that arrived at `t` (monotonic s; None: now)."""
        with self.lock:
            if not self.can_move:
                return False
            self._follow(time.monotonic() if t is None else t)  # toward the target it replaces, until now
            self.target = np.asarray(q, dtype=float).copy()
            self.lookahead = min(max(float(lookahead), 0.03), 0.2)
            self.servo_commands += 1
            return True

    def servo_stop(self) -> None:
        with self.lock:
            self.target = self.q_cmd = self.q.copy()

    def set_tcp(self, offset: Sequence[float]) -> None:
        with self.lock:
            self.tcp_offset = np.concatenate([np.asarray(offset[:3], float), rotvec_to_quat(offset[3:])])

    # -- dashboard ------------------------------------------------------------------------------------
    def power_on(self) -> None:
        with self.lock:
            if self.robot_mode == POWER_OFF and self.safety_mode == NORMAL:
                self.robot_mode = IDLE

    def power_off(self) -> None:
        with self.lock:
            self.robot_mode = POWER_OFF
            self.servo_stop()

    def brake_release(self) -> None:
        with self.lock:
            if self.robot_mode == IDLE:
                self.robot_mode = RUNNING
                self.servo_stop()

    def unlock_protective_stop(self) -> bool:
        with self.lock:
            if self.safety_mode != PROTECTIVE_STOP:
                return False
            self.safety_mode = NORMAL
            self.servo_stop()
            return True

    # -- fault injection (tests) ----------------------------------------------------------------------
    def reset(self) -> None:
        """Back to a freshly booted controller at home (model backend), so one emulator process can serve
        many tests: starting a process costs a second or more on a loaded machine. The joints of a sim
        backend are the world's and stay where they are."""
        with self.lock:
            if isinstance(self.joints, ModelJoints):
                self.joints.q = np.asarray(self.model.home, dtype=float).copy()
            self.q = self.joints.read()
            self.qd = np.zeros(6)
            self.target = self.q_cmd = self.q.copy()
            self.lookahead = 0.1
            self.robot_mode, self.safety_mode = RUNNING, NORMAL
            self.speed_slider, self.remote_control = 1.0, True
            self.program, self.program_playing = None, False
            self.tcp_offset = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])

    def protective_stop(self) -> None:
        """As a collision or a safety limit would: the arm stops where it is, the program stops."""
        with self.lock:
            self.safety_mode = PROTECTIVE_STOP
            self.servo_stop()
            self.program_playing = False

    def emergency_stop(self) -> None:
        with self.lock:
            self.safety_mode = ROBOT_EMERGENCY_STOP
            self.servo_stop()
            self.program_playing = False

    def release_emergency_stop(self) -> None:
        """The button pulled out: safety normal, the arm powered off (power on and release the brakes)."""
        with self.lock:
            if self.safety_mode == ROBOT_EMERGENCY_STOP:
                self.safety_mode = NORMAL
                self.robot_mode = POWER_OFF
