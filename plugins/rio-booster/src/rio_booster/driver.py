"""`booster.t1`: a Booster T1 (23 joints) in joint space on Booster's SDK (`booster_robotics_sdk_python`).

The SDK speaks DDS (a Fast DDS built into the extension, namespaced `booster_eprosima`): the robot publishes
`rt/low_state` (`LowState`: `motor_state_serial` / `motor_state_parallel` q, dq, ddq, tau_est per motor;
`imu_state` rpy, gyro, acc), takes `rt/joint_ctrl` (`LowCmd`: `cmd_type` SERIAL or PARALLEL, one `MotorCmd`
q, dq, tau, kp, kd, weight, mode per motor), and serves its mode changes as an RPC (`B1LocoClient`, on
`rt/LocoApiTopic`). `ChannelFactory.Instance().Init(domain_id, interface)` starts DDS once per process.

Each cycle reads the newest low state (taken by the SDK's subscriber callback on its own thread, copied)
and sends one SERIAL command (joint space; ankles as pitch/roll); the humanoid kind owns the targets
(interpolation, limits, max step, the watchdog). The robot obeys `rt/joint_ctrl` only in its custom mode:

- enable: (with `loco`) prepare mode first when the robot is not in prepare or custom (its own controller
  stands it in the preparation pose; `prepare_s` to settle), one command holding the measured pose, then
  `ChangeMode(kCustom)`;
- disable, a fault, close: damping on the wire (kp = 0, each joint's `damping_kd`) and `ChangeMode(kDamping)`;
  while disabled after having had control, damping every cycle.

Safety, by the driver itself (each a named fault, `rio.interfaces.damping`): no low state for
`state_timeout_s` (`lowstate_timeout`); the trunk tilted beyond `fall_tilt_deg` (from the IMU's roll and
pitch, `ImuState.rpy`); a stream of commands that stops (the kind's watchdog hold) with
`on_stale = "damp"`. Each leaves the node disabled, sending damping (kp = 0) and asking the robot for its
damping mode (`B1LocoClient.ChangeMode(kDamping)`), until `clear_faults()`.
"""

from __future__ import annotations

import importlib
import logging
import threading
import time
from typing import Any

import numpy as np
from pydantic import Field

from rio import clock
from rio.control.rotations import euler_to_quat
from rio.interfaces import BodyDampingConfig, DampingGuard, FaultHolder, HumanoidNode, MotorGainsConfig, motor_gains
from rio.interfaces.damping import state_lost, tilt_from_rpy

from . import t1
from .commands import Commands, Frame, to_low_cmd

log = logging.getLogger("rio_booster")

SDK = "booster_robotics_sdk_python"
EMULATOR = "rio_booster.emulator"
#: The SDK's RobotMode values (kUnknown -1, kDamping 0, kPrepare 1, kWalking 2, kCustom 3, kSoccer 4).
MODE_NAMES = {-1: "unknown", 0: "damping", 1: "prepare", 2: "walking", 3: "custom", 4: "soccer"}
DAMPING, PREPARE, CUSTOM = 0, 1, 3

# ChannelFactory is one per process: {module name: (domain_id, interface)} it was started with
_factory_started: dict[str, tuple[int, str]] = {}
_factory_lock = threading.Lock()


def load_sdk(name: str) -> Any:
    try:
        return importlib.import_module(name)
    except ImportError as e:
        if name == SDK:
            raise ImportError(f"{SDK} is not installed ({e}): pip install booster-robotics-sdk-python (CPython "
                              "3.11, Linux x86-64), or build it from Booster's sources; "
                              f"sdk = '{EMULATOR}' runs the driver against the emulator") from e
        raise


def start_channels(sdk: Any, domain_id: int, interface: str) -> None:
    """`ChannelFactory.Instance().Init(...)` once per process; a second node asking for another domain or
    interface is refused (the SDK's factory cannot serve two)."""
    with _factory_lock:
        started = _factory_started.get(sdk.__name__)
        if started is not None and not getattr(sdk, "CHANNEL_FACTORY_REINIT", False):
            if started != (domain_id, interface):
                raise ValueError(f"this process already started the Booster SDK's DDS on domain {started[0]}, "
                                 f"interface '{started[1]}'; it cannot also serve domain {domain_id}, interface "
                                 f"'{interface}' (run that node in another process)")
            return
        sdk.ChannelFactory.Instance().Init(domain_id, interface)
        _factory_started[sdk.__name__] = (domain_id, interface)


class T1(HumanoidNode):
    class Config(BodyDampingConfig, MotorGainsConfig, HumanoidNode.Config):
        defaults = {"max_step_rad": 0.004}  # 2 rad/s at 500 Hz
        interface: str = Field("", description="network interface on the robot's network, by name or address "
                                               "(Booster's examples pass the address, e.g. '127.0.0.1'); '' for "
                                               "the SDK's default. With sdk = 'rio_booster.emulator' it names "
                                               "the emulator's backend: '' ideal joints, 'sim' rio-sim physics "
                                               "(README)")
        domain_id: int = Field(0, ge=0, le=232, description="DDS domain (the robot's is 0)")
        sdk: str = Field(SDK, description=f"module offering the SDK's API: '{SDK}' (the robot), or "
                                          f"'{EMULATOR}' (an emulated T1 in this process, no DDS)")
        loco: bool = Field(True, description="change the robot's mode through B1LocoClient (prepare -> custom on "
                                             "enable; damping on disable, fault and close); false: put the robot "
                                             "in custom mode yourself")
        prepare_s: float = Field(3.0, ge=0, description="seconds to let the robot settle in prepare mode before "
                                                        "custom (only when it was not in prepare or custom)")
        motor_mode: int = Field(0, description="MotorCmd.mode of every motor (the SDK's examples send 0)")
        torque_limit: bool = Field(True, description="clip each goal to where kp * error stays within the motor's "
                                                     "effort limit")

    # -- setup --------------------------------------------------------------------------------------
    def default_joint_names(self) -> list[str]:
        return t1.joint_names()

    def setup(self) -> None:
        super().setup()
        c = self.config
        self.joints = t1.lookup(self.joint_list)
        self.idx = np.array([j.index for j in self.joints], dtype=np.intp)
        self.gains = motor_gains(c, {"kp": [j.kp for j in self.joints], "kd": [j.kd for j in self.joints],
                                     "damping_kd": [j.damping for j in self.joints]}, self.name, self.dof)
        self.example_data = {**self.example_data, "robot_mode": -1}
        where = "the emulator" if c.sdk == EMULATOR else f"interface '{c.interface or 'default'}'"
        self.safety = DampingGuard(self, self.state_lost, tilt=self.tilt_deg, body="trunk")
        self.faults = FaultHolder(self, f"the T1 on {where} (DDS domain {c.domain_id})", ask=self.safety.device_fault,
                                  on_report=self._on_fault)
        self.sdk: Any = None
        self._lock = threading.Lock()
        self._state: dict[str, np.ndarray] | None = None
        self.n_states = 0
        self.robot_mode = -1
        self._in_control = False  # the robot is in custom mode by us (we owe it damping when we let go)
        self._had_control = False  # we took control once: while disabled, damping on the wire every cycle
        self._sub = self._pub = self._loco = None

    # -- hardware -----------------------------------------------------------------------------------
    def open(self) -> None:
        c = self.config
        self.sdk = sdk = load_sdk(c.sdk)
        start_channels(sdk, c.domain_id, c.interface)
        try:
            self._sub = sdk.B1LowStateSubscriber(self._on_low_state)
            self._sub.InitChannel()
            self._pub = sdk.B1LowCmdPublisher()
            self._pub.InitChannel()
            if c.loco:
                self._loco = sdk.B1LocoClient()
                self._loco.Init()
            deadline = time.monotonic() + c.connect_timeout_s
            while self.n_states == 0:
                if time.monotonic() > deadline:
                    raise TimeoutError(
                        f"no rt/low_state on interface '{c.interface or 'default'}' (DDS domain {c.domain_id}) "
                        f"within {c.connect_timeout_s} s: is the robot on, and this computer on its network?")
                time.sleep(0.005)
            self.robot_mode = self._get_mode()
        except BaseException:
            self._close_channels()
            raise
        lower, upper = self.hardware_limits()
        self.wire = Commands(self.joints, self.gains["kp"], self.gains["kd"], self.gains["damping_kd"],
                             np.array(lower), np.array(upper), c.torque_limit)

    def close(self) -> None:
        if self._pub is None:
            return
        try:
            if self.config.disable_on_close and self._had_control:
                self._let_go()
        finally:
            self._close_channels()

    def hardware_limits(self) -> tuple[list[float], list[float]]:
        return [j.lower for j in self.joints], [j.upper for j in self.joints]

    def default_home(self) -> list[float]:
        return t1.home_pose(self.joint_list)

    def robot_description(self) -> dict[str, Any] | None:
        """rio-sim's T1 (Booster's model as MuJoCo Menagerie publishes it: the real kinematics, same joint names
        and order) with its hands' tool sites as IK frames, when rio-sim is installed (imported here, not
        with the driver); None otherwise. The T1's arms have no wrist: the hands' IK asks for position first
        (rio-sim's `t1.IK`)."""
        try:
            from rio_sim import t1 as sim_t1
        except ImportError:
            return None
        return {"format": "mjcf", "xml": sim_t1.asset_text(), "joints": list(self.joint_list),
                "frames": dict(sim_t1.FRAMES), "frame_type": "site", "home": self.default_home(), **sim_t1.IK}

    def set_enabled(self, enabled: bool) -> None:
        if enabled:
            self._take_control()
        elif self._pub is not None and self._in_control:
            self._let_go()

    def state_lost(self, age: float) -> Any:
        c = self.config
        return state_lost("lowstate_timeout", "rt/low_state", age, f"interface '{c.interface or 'default'}' (DDS "
                          f"domain {c.domain_id})", "check the cable, the interface's address (192.168.10.x) and "
                          "that the robot is on")

    def tilt_deg(self) -> float | None:
        with self._lock:
            s = self._state
        return None if s is None else tilt_from_rpy(s["rpy"])

    # -- cycle --------------------------------------------------------------------------------------
    def read_joints(self) -> dict[str, Any]:
        self.safety.watch()
        s = self.state()
        quat = euler_to_quat(*s["rpy"])
        return {"joint_pos": s["q"][self.idx], "joint_vel": s["dq"][self.idx], "base_quat": quat,
                "base_ang_vel": s["gyro"].copy(), "robot_mode": int(self.robot_mode)}

    def _on_fault(self, fault: Any) -> None:
        """A fault stopped the node: damping on the wire and in the robot's own mode, if it was ours."""
        if self._in_control:
            self._let_go()

    def write_disabled(self) -> None:
        """Damping on the wire every cycle while disabled, once we had control (before, the robot is its own)."""
        if self._had_control:
            self._send(self.wire.damping())

    def write_joints(self, joint_pos: np.ndarray) -> None:
        self._send(self.wire.position(joint_pos, self.state()["q"][self.idx]))

    # -- helpers ------------------------------------------------------------------------------------
    def state(self) -> dict[str, np.ndarray]:
        with self._lock:
            s = self._state
        assert s is not None
        return s

    def _on_low_state(self, msg: Any) -> None:
        """The SDK's callback (its thread): copy what we use out of the message."""
        motors = msg.motor_state_serial
        imu = msg.imu_state
        s = {"q": np.array([m.q for m in motors], np.float64), "dq": np.array([m.dq for m in motors], np.float64),
             "tau": np.array([m.tau_est for m in motors], np.float64), "rpy": np.array(imu.rpy, np.float64),
             "gyro": np.array(imu.gyro, np.float64)}
        if s["q"].shape != (t1.NUM_JOINTS,):
            return  # not a 23-joint T1 (or a parallel-only message): ignored
        with self._lock:
            self._state, self.safety.t_state = s, clock.now()
            self.n_states += 1

    def _get_mode(self) -> int:
        if self._loco is None:
            return -1
        try:
            return int(self._loco.GetMode().mode)
        except Exception as e:  # an SDK without GetMode, or no answer: unknown, not fatal
            log.warning("node '%s': could not read the robot's mode: %s", self.name, e)
            return -1

    def _change_mode(self, mode: int) -> None:
        if self._loco is None:
            return
        name = MODE_NAMES.get(mode, str(mode))
        try:
            ret = self._loco.ChangeMode(self.sdk.RobotMode(mode))
        except Exception as e:
            raise RuntimeError(f"node '{self.name}': ChangeMode({name}) failed: {e}") from e
        if isinstance(ret, int) and ret != 0:  # older SDKs return a status code
            raise RuntimeError(f"node '{self.name}': ChangeMode({name}) refused (code {ret})")
        self.robot_mode = mode

    def _take_control(self) -> None:
        """Prepare (when needed), hold the measured pose on the wire, then custom mode."""
        c = self.config
        if c.loco:
            self.robot_mode = self._get_mode()
            if self.robot_mode not in (PREPARE, CUSTOM):
                self._change_mode(PREPARE)
                time.sleep(c.prepare_s)
        q_all = self.state()["q"]
        self.wire.hold_others_at(q_all)
        self._send(self.wire.position(q_all[self.idx], q_all[self.idx]))
        if c.loco and self.robot_mode != CUSTOM:
            self._change_mode(CUSTOM)
        self._in_control = self._had_control = True

    def _let_go(self) -> None:
        """Damping on the wire and in the robot's own mode."""
        self._send(self.wire.damping())
        self._in_control = False
        try:
            self._change_mode(DAMPING)
        except RuntimeError as e:
            self._in_control = True  # the next disable or fault asks again (damping goes out every cycle)
            log.error("%s", e)

    def _send(self, frame: Frame) -> None:
        if self._pub is not None:
            self._pub.Write(to_low_cmd(self.sdk, frame, self.config.motor_mode))

    def _close_channels(self) -> None:
        for ch in (self._sub, self._pub):
            if ch is not None:
                try:
                    ch.CloseChannel()
                except Exception as e:  # closing goes on
                    log.warning("node '%s': closing a channel failed: %s", self.name, e)
        self._sub = self._pub = self._loco = None
