"""An emulated Booster T1 behind an SDK-object fake: the names the driver calls in `booster_robotics_sdk_python`
(`ChannelFactory`, `B1LowStateSubscriber`, `B1LowCmdPublisher`, `B1LocoClient`), with the same signatures,
served in this process by `EmulatedT1` instead of DDS. Point the driver at it with `sdk = "rio_booster.emulator"`.

Why a fake and not a second DDS participant (as rio-unitree's bridge is): the SDK has no publisher for
`rt/low_state` and no subscriber for `rt/joint_ctrl` (it only ever plays the controller's side), its
`MotorState` fields are read-only from Python, and its DDS (Fast DDS built into the extension) would have
to be matched from outside with Booster's IDL and its loco RPC protocol, neither of which it publishes.

What is real: the command objects. With the SDK installed, `LowCmd`, `MotorCmd`, `LowCmdType` and
`RobotMode` here ARE the SDK's, so the driver builds the very `LowCmd` it would write to the robot and the
emulator reads it back field by field. (Without the SDK, plain stand-ins with the same attributes.)

What is emulated: 23 joints in the SDK's order, each an inertia with the robot's motor law
tau = kp (q* - q) + kd (dq* - dq) + tau_ff, limited to its effort, plus a little viscous friction; no
gravity, no contacts (a robot hanging on its gantry whose joints are perfectly balanced). The robot's
modes: damping (kd only: the robot's own damping), prepare and walking (Booster's controller holds the
preparation pose: here the model's stand), custom (the last SERIAL `rt/joint_ctrl`; PARALLEL commands
are counted and ignored). As on the robot, custom is entered only from prepare or walking, and commands
are obeyed only in custom. The IMU reports a trunk orientation the test sets (`tilt()`), a fall as the
IMU sees one. Low state is published at `rate_hz` to each subscriber's handler, as the SDK's DDS thread
does, from a thread of its own on its own schedule: the physics runs in another, and the state
published is the physics' latest. A robot's state stream does not stop while a host's CPU is
contended; this emulator's did when both were one thread: the physics (MuJoCo steps, the world bus)
went with the state, and a loaded machine saw no state for up to 0.46 s, which the driver rightly
took for a lost robot (lowstate_timeout). Now the physics holds no lock while it steps, a late
physics tick simulates at most `MAX_STEP_S` (it drops time rather than catching up), and a late
publisher skips to its next slot rather than bursting.

Backends (`backend`): "ideal" (the above); "sim" (or "sim:floating", "sim@WORLD"): rio-sim's T1 in
MuJoCo, mounted on its stand at rio-sim's T1 table (`emulator_sim`): the same motor law on MuJoCo's
torque motors at the physics rate, gravity and contacts real, the IMU the trunk's; the emulator serves
that physics as the station's sim world (`sim.camera` renders it). The driver chooses the backend with
the one free field it hands the SDK: with this module, `interface` names the backend ('' = "ideal").
"""

from __future__ import annotations

import enum
import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .commands import Frame, from_low_cmd
from .t1 import JOINTS, NUM_JOINTS, home_pose

try:  # the SDK's own command types, when installed
    import booster_robotics_sdk_python as _sdk
except ImportError:  # pragma: no cover - exercised where the SDK has no wheel
    _sdk = None

#: The driver may start this module's ChannelFactory again (each EmulatedT1 is its own domain).
CHANNEL_FACTORY_REINIT = True
kJointCnt = NUM_JOINTS

if _sdk is not None:
    LowCmd, MotorCmd, LowCmdType, RobotMode = _sdk.LowCmd, _sdk.MotorCmd, _sdk.LowCmdType, _sdk.RobotMode
    SDK_TYPES = True
else:  # pragma: no cover
    SDK_TYPES = False

    class LowCmdType(enum.IntEnum):  # type: ignore[no-redef]
        PARALLEL = 0
        SERIAL = 1

    class RobotMode(enum.IntEnum):  # type: ignore[no-redef]
        kUnknown = -1
        kDamping = 0
        kPrepare = 1
        kWalking = 2
        kCustom = 3
        kSoccer = 4

    @dataclass
    class MotorCmd:  # type: ignore[no-redef]
        mode: int = 0
        q: float = 0.0
        dq: float = 0.0
        tau: float = 0.0
        kp: float = 0.0
        kd: float = 0.0
        weight: float = 0.0

    class LowCmd:  # type: ignore[no-redef]
        def __init__(self) -> None:
            self.cmd_type = LowCmdType.PARALLEL
            self.motor_cmd: list[MotorCmd] = []

        def resize_motor_cmd(self, size: int) -> None:
            self.motor_cmd = [MotorCmd() for _ in range(size)]

        def motor_cmd_at(self, index: int) -> MotorCmd:
            return self.motor_cmd[index]

        def motor_cmd_size(self) -> int:
            return len(self.motor_cmd)


DAMPING, PREPARE, WALKING, CUSTOM = 0, 1, 2, 3
IDEAL = "ideal"
#: The most physics time one late tick simulates (s): beyond it the emulated time falls behind instead.
MAX_STEP_S = 0.02
_NEWEST = object()  # motor_law's default: the newest command
_robots: dict[int, EmulatedT1] = {}
_registry_lock = threading.Lock()


# -- the emulated robot -------------------------------------------------------------------------------
@dataclass
class _Motor:
    q: float
    dq: float
    ddq: float = 0.0
    tau_est: float = 0.0
    temperature: int = 35
    lost: int = 0
    mode: int = 0


@dataclass
class _Imu:
    rpy: list[float]
    gyro: list[float]
    acc: list[float]


@dataclass
class _LowState:
    imu_state: _Imu
    motor_state_serial: list[_Motor]
    motor_state_parallel: list[_Motor]


@dataclass
class _ModeResponse:
    mode: Any


@dataclass
class Counts:
    states: int = 0
    lowcmd: int = 0
    parallel: int = 0
    obeyed: int = 0


def _inertia(name: str) -> float:
    """kg·m² seen by each joint: a rough T1 (head 0.6 kg, arms 1.5 kg, legs 2-4 kg per link)."""
    if "Head" in name:
        return 0.005
    if "Ankle" in name:
        return 0.01
    if "Knee" in name:
        return 0.05
    if "Hip" in name or name == "Waist":
        return 0.1
    return 0.03


class EmulatedT1:
    """A T1 behind the fake SDK on `domain_id` (one per domain in this process). `with EmulatedT1(...) as robot`."""

    def __init__(self, domain_id: int = 0, rate_hz: float = 500.0, mode: int = PREPARE,
                 start_q: Any = None, loco: bool = True, backend: str = IDEAL):
        self.domain_id = domain_id
        self.backend = backend or IDEAL
        self.rate_hz = rate_hz
        self.mode = mode
        self.modes: list[int] = [mode]
        self.loco = loco  # False: the loco service does not answer (ChangeMode raises)
        self.prepare_q = np.array(home_pose(), np.float64)
        self.q = self.prepare_q.copy() if start_q is None else np.asarray(start_q, np.float64).copy()
        self.dq = np.zeros(NUM_JOINTS)
        self.tau = np.zeros(NUM_JOINTS)
        self.rpy = np.zeros(3)
        self.gyro = np.zeros(3)
        self.inertia = np.array([_inertia(j.name) for j in JOINTS])
        self.effort = np.array([j.effort for j in JOINTS])
        self.lower, self.upper = np.array([j.lower for j in JOINTS]), np.array([j.upper for j in JOINTS])
        self.damping_kd = np.array([j.damping for j in JOINTS])
        self.friction = 0.2
        self.counts = Counts()
        self.frames: list[Frame] = []  # every SERIAL command received (newest last)
        self.publishing = True
        self.owned_by_channels = False
        self._last: Frame | None = None
        self._arrivals: list[tuple[float, Frame]] = []  # commands since the last physics tick, with their time
        self._in_force: Frame | None = None  # the command the physics obeyed at the end of its last tick
        self._handlers: list[Any] = []
        self._lock = threading.Lock()  # the published state, the commands, the mode: held briefly
        self._physics_lock = threading.Lock()  # the physics' own data, held while stepping
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._publisher: threading.Thread | None = None
        self.physics: Any = None  # the sim backend's (rio_booster.emulator_sim.SimT1Physics)
        if self.backend != IDEAL:
            if not self.backend.startswith("sim"):
                raise ValueError(f"unknown emulated T1 backend '{backend}': 'ideal' or 'sim[:floating][@WORLD]'")
            from . import emulator_sim

            self.physics = emulator_sim.make(self.backend, self.q)
            self.q, self.dq, self.tau, self.rpy, self.gyro = self._physics_state()

    # -- test controls ---------------------------------------------------------------------------------
    def tilt(self, degrees: float) -> None:
        """Turn the trunk forward (pitch) by `degrees`: what a fall looks like to the IMU."""
        self.rpy = np.array([0.0, math.radians(degrees), 0.0])
        if self.physics is not None:
            with self._physics_lock:
                self.physics.tilt(self.rpy)
                state = self._physics_state()
            with self._lock:
                self.q, self.dq, self.tau, self.rpy, self.gyro = state

    def joint_pos(self) -> np.ndarray:
        with self._lock:
            return self.q.copy()

    @property
    def last_frame(self) -> Frame | None:
        with self._lock:
            return self._last

    # -- the fake SDK's side -------------------------------------------------------------------------
    def subscribe(self, handler: Any) -> None:
        with self._lock:
            self._handlers.append(handler)

    def unsubscribe(self, handler: Any) -> None:
        with self._lock:
            if handler in self._handlers:
                self._handlers.remove(handler)

    def receive(self, cmd: Any) -> None:
        frame, serial = from_low_cmd(cmd)
        with self._lock:
            self.counts.lowcmd += 1
            if not serial:
                self.counts.parallel += 1
                return
            if frame.q.shape != (NUM_JOINTS,):
                return
            self._last = frame
            self._arrivals.append((time.monotonic(), frame))
            self.frames.append(frame)
            if self.mode == CUSTOM:
                self.counts.obeyed += 1

    def change_mode(self, mode: int) -> None:
        if not self.loco:
            raise RuntimeError("the loco service did not answer (timeout)")
        with self._lock:
            if mode == CUSTOM and self.mode not in (PREPARE, WALKING, CUSTOM):
                raise RuntimeError("state transition failed: custom mode is entered from prepare or walking")
            self.mode = mode
            self.modes.append(mode)

    # -- running -------------------------------------------------------------------------------------
    def start(self) -> EmulatedT1:
        with _registry_lock:
            if self.domain_id in _robots:
                raise RuntimeError(f"an emulated T1 already runs on domain {self.domain_id}")
            _robots[self.domain_id] = self
        if self.physics is not None:
            try:
                self.physics.open_bus()
            except BaseException:
                with _registry_lock:
                    del _robots[self.domain_id]
                raise
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name=f"emulated-t1-{self.domain_id}", daemon=True)
        self._publisher = threading.Thread(target=self._publish_loop, name=f"emulated-t1-{self.domain_id}-state",
                                           daemon=True)
        self._thread.start()
        self._publisher.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        for thread in (self._thread, self._publisher):
            if thread is not None:
                thread.join(timeout=5.0)
        self._thread = self._publisher = None
        if self.physics is not None:
            self.physics.close_bus()
        with _registry_lock:
            if _robots.get(self.domain_id) is self:
                del _robots[self.domain_id]

    def __enter__(self) -> EmulatedT1:
        return self.start()

    def __exit__(self, *exc: Any) -> None:
        self.stop()

    def _run(self) -> None:
        """The physics, at `rate_hz`: each tick simulates the time since the last (at most `MAX_STEP_S`)."""
        t_last = time.monotonic()
        for now in self._schedule():
            self.step(min(now - t_last, MAX_STEP_S), now)
            t_last = now

    def _publish_loop(self) -> None:
        """The low state, at `rate_hz`, whatever the physics is doing (see the module docstring)."""
        for _ in self._schedule():
            if self.publishing:
                self._publish()

    def _schedule(self) -> Any:
        """Yields the time of each tick at `rate_hz` until stopped; a late tick is not made up for (the
        next one is the next slot after now), so a stall never turns into a burst of ticks."""
        period = 1.0 / self.rate_hz
        next_t = time.monotonic()
        while not self._stop.is_set():
            now = time.monotonic()
            yield now
            next_t += period
            now = time.monotonic()
            if next_t < now:
                next_t += math.ceil((now - next_t) / period) * period
            self._stop.wait(next_t - now)

    def motor_law(self, frame: Any = _NEWEST) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                                         bool]:
        """What the motors do in the present mode under the command `frame` (default: the newest; None: none
        yet): tau = kp (q* - q) + kd (dq* - dq) + tau_ff, as (kp, kd, q*, dq*, tau_ff, plus the joints'
        gravity torque). Call under the lock."""
        zeros = np.zeros(NUM_JOINTS)
        f = self._last if frame is _NEWEST else frame
        if self.mode == CUSTOM and f is not None:
            return f.kp, f.kd, f.q, f.dq, f.tau, False
        if self.mode in (PREPARE, WALKING):  # Booster's controller stands it in the preparation pose
            return np.full(NUM_JOINTS, 100.0), np.full(NUM_JOINTS, 5.0), self.prepare_q, zeros, zeros, True
        return zeros, self.damping_kd, zeros, zeros, zeros, False  # damping (and custom with no command yet)

    def step(self, seconds: float, now: float | None = None) -> None:
        """Advance the joints over the `seconds` up to `now` (monotonic s; None: now) under the present mode's
        motor law, each command from when it arrived, the one before it until then (ideal: substeps of at
        most 0.5 ms; sim: the physics' own steps): a tick after this thread was late obeyed the newest
        command over time before it came. The state lock is held only to read the laws and to store the
        result, never while stepping: the publisher reads the state meanwhile."""
        now = time.monotonic() if now is None else now
        with self._lock:
            laws = self._laws(now - seconds, now)
            q, dq, tau = self.q.copy(), self.dq.copy(), self.tau.copy()
        with self._physics_lock:
            if self.physics is not None:
                for span, (kp, kd, q_goal, dq_goal, tau_ff, hold) in laws:
                    self.physics.step(span, kp, kd, q_goal, dq_goal, tau_ff, hold_gravity=hold)
                self.physics.publish_bus()
                state = self._physics_state()
                with self._lock:
                    self.q, self.dq, self.tau, self.rpy, self.gyro = state
                return
            for span, (kp, kd, q_goal, dq_goal, tau_ff, _) in laws:
                n = max(1, math.ceil(span / 0.0005))
                dt = span / n
                for _ in range(n):
                    tau = kp * (q_goal - q) + kd * (dq_goal - dq) + tau_ff  # no gravity here to hold
                    tau = np.clip(tau, -self.effort, self.effort)
                    ddq = (tau - self.friction * dq) / self.inertia
                    dq = dq + dt * ddq
                    q = q + dt * dq
                    hit = (q < self.lower) | (q > self.upper)  # hard stops
                    q = np.clip(q, self.lower, self.upper)
                    dq[hit] = 0.0
        with self._lock:
            self.q, self.dq, self.tau = q, dq, tau

    def _laws(self, start: float, end: float) -> list[tuple[float, tuple]]:
        """(seconds, motor law) pieces covering [start, end]: the command in force at `start`, then each that
        arrived within, from its arrival. Call under the lock."""
        arrivals, self._arrivals = self._arrivals, []
        pieces, t, frame = [], start, self._in_force
        for t_arrived, f in arrivals:
            t_arrived = min(t_arrived, end)
            if t_arrived > t:
                pieces.append((t_arrived - t, self.motor_law(frame)))
                t = t_arrived
            frame = f
        pieces.append((max(end - t, 0.0), self.motor_law(frame)))
        self._in_force = frame
        return pieces

    def _physics_state(self) -> tuple[np.ndarray, ...]:
        """q, dq, tau, rpy, gyro of the physics (under `_physics_lock`)."""
        q, dq, tau = self.physics.joints()
        rpy, gyro = self.physics.imu()
        return q, dq, tau, rpy, gyro

    def _publish(self) -> None:
        with self._lock:
            motors = [_Motor(float(q), float(dq), 0.0, float(t)) for q, dq, t in zip(self.q, self.dq, self.tau,
                                                                                    strict=True)]
            r, p, _ = self.rpy
            g = 9.81
            acc = [-g * math.sin(p), g * math.sin(r) * math.cos(p), g * math.cos(r) * math.cos(p)]
            msg = _LowState(_Imu(list(map(float, self.rpy)), list(map(float, self.gyro)), acc), motors, list(motors))
            handlers = list(self._handlers)
            self.counts.states += 1
        for h in handlers:
            h(msg)


def robot(domain_id: int) -> EmulatedT1 | None:
    with _registry_lock:
        return _robots.get(domain_id)


# -- the fake SDK ---------------------------------------------------------------------------------------
class ChannelFactory:
    _instance: ChannelFactory | None = None

    def __init__(self) -> None:
        self.domain_id: int | None = None
        self.network_interface = ""

    @staticmethod
    def Instance() -> ChannelFactory:  # noqa: N802 - the SDK's names
        if ChannelFactory._instance is None:
            ChannelFactory._instance = ChannelFactory()
        return ChannelFactory._instance

    def Init(self, domain_id: int, network_interface: str = "") -> None:  # noqa: N802
        self.domain_id, self.network_interface = int(domain_id), str(network_interface)


def _bind() -> EmulatedT1:
    """The robot of the factory's domain; one is started (and owned by the channels) when none runs."""
    domain = ChannelFactory.Instance().domain_id
    if domain is None:
        raise RuntimeError("ChannelFactory.Instance().Init(domain_id, interface) was not called")
    with _registry_lock:
        r = _robots.get(domain)
    if r is None:
        r = EmulatedT1(domain_id=domain, backend=ChannelFactory.Instance().network_interface or IDEAL).start()
        r.owned_by_channels = True
    return r


@dataclass
class _Channel:
    robot: EmulatedT1 | None = None
    closed: bool = field(default=False)

    def _release(self) -> None:
        r = self.robot
        self.robot = None
        if r is not None and r.owned_by_channels and not r._handlers:
            r.stop()


class B1LowStateSubscriber:
    def __init__(self, handler: Any) -> None:
        self._handler = handler
        self._ch = _Channel()

    def InitChannel(self) -> None:  # noqa: N802
        self._ch.robot = _bind()
        self._ch.robot.subscribe(self._handler)

    def CloseChannel(self) -> None:  # noqa: N802
        if self._ch.robot is not None:
            self._ch.robot.unsubscribe(self._handler)
            self._ch._release()

    def GetChannelName(self) -> str:  # noqa: N802
        return "rt/low_state"


class B1LowCmdPublisher:
    def __init__(self) -> None:
        self._ch = _Channel()

    def InitChannel(self) -> None:  # noqa: N802
        self._ch.robot = _bind()

    def Write(self, msg: Any) -> bool:  # noqa: N802
        if self._ch.robot is None:
            return False
        self._ch.robot.receive(msg)
        return True

    def CloseChannel(self) -> None:  # noqa: N802
        self._ch._release()

    def GetChannelName(self) -> str:  # noqa: N802
        return "rt/joint_ctrl"


class B1LocoClient:
    def __init__(self) -> None:
        self._robot: EmulatedT1 | None = None

    def Init(self) -> None:  # noqa: N802
        self._robot = _bind()

    def _r(self) -> EmulatedT1:
        if self._robot is None:
            raise RuntimeError("B1LocoClient.Init() was not called")
        return self._robot

    def ChangeMode(self, mode: Any) -> None:  # noqa: N802
        self._r().change_mode(int(mode))

    def GetMode(self) -> _ModeResponse:  # noqa: N802
        r = self._r()
        if not r.loco:
            raise RuntimeError("the loco service did not answer (timeout)")
        return _ModeResponse(RobotMode(r.mode))
