"""Unitree's DDS hands in joint space: `DdsHand`, what every one shares (the topics, the damping safety),
and `unitree.dex3`, one Dex3-1 hand (config `side`) on its own topics (`unitree.inspire`: `inspire.py`).

`DdsHand` opens one participant, a reader of the hand's state topic and a writer of its command topic,
waits for the first state at open, and sends one command per cycle: the driver's `position(goal,
measured)` while enabled, its `damping()` while disabled or faulted and a moment before closing.

The Dex3-1: each cycle reads the newest `rt/dex3/<side>/state` and sends one `rt/dex3/<side>/cmd`: every motor
with its id and status "enabled" in its mode byte (`rio_unitree.dex3`), `q` = the goal clipped to its
limits (and, with `torque_limit`, to where kp * error stays within its effort), `dq = 0`, `tau = 0`,
and its kp, kd. The hand kind owns the targets (interpolation, limits, max step, the watchdog).

The body's damping safety (`rio.interfaces.damping`, as `unitree.g1`), for every hand: no hand state for
`state_timeout_s` is a named fault (`handstate_timeout`), no state at open a named error; a stream of
commands that stops (the kind's watchdog) damps the hand with `on_stale = "damp"` (a Dex3-1: kp = 0, each
joint's `damping_kd`); a disabled or faulted node sends damping every cycle, and closing it sends damping
a moment before it lets go.

`robot_description()` is rio-sim's Dex3-1 of that side (cut out of its G1-with-hands model, palm site in
RIO's palm frame, finger keypoints as sites) when rio-sim is installed, so `rio teleop`'s hand trackers
retarget onto it.
"""

from __future__ import annotations

import logging
import time
from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio import clock
from rio.interfaces import FAULT_KEYS, DampingConfig, DampingSafety, Fault, HandNode, MotorGainsConfig, motor_gains
from rio.interfaces.damping import state_lost

from . import dex3
from .dds import Participant
from .hand_wire import HandCmd, HandState

log = logging.getLogger("rio_unitree")

class DdsHand(DampingSafety, HandNode):
    """A hand behind a Unitree DDS state/command topic pair. The driver sets `state_topic`, `cmd_topic`,
    `device_label` and `device_hint` in `setup()`, and defines `decode_state` (bytes -> its state, None
    when it is not this hand's), `joint_state` (its q and dq of this node's joints, rad), `position` and
    `damping` (messages with `encode()`)."""

    device_noun = "hand"
    state_topic: str
    cmd_topic: str
    #: What open()'s timeout asks about ("is the left Dex3-1 on and connected ...?").
    device_hint = "the hand"

    class Config(DampingConfig, HandNode.Config):
        interface: str = Field("eth0", description="network interface on the robot's network (192.168.123.x; "
                                                   "'lo' for the bridge on this machine)")
        domain_id: int = Field(0, ge=0, le=232, description="DDS domain (the robot's is 0)")
        rate_hz: float = Field(100.0, gt=0, description="loop rate (Hz)")

    # -- driver hooks ---------------------------------------------------------------------------------
    def decode_state(self, data: bytes) -> Any:
        raise NotImplementedError

    def joint_state(self, state: Any) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def position(self, goal: np.ndarray, measured: np.ndarray) -> Any:
        raise NotImplementedError

    def damping(self) -> Any:
        raise NotImplementedError

    def open_topics(self, dds: Participant) -> None:
        """More topics the driver needs, opened with the others (none by default)."""

    # -- setup --------------------------------------------------------------------------------------
    def setup(self) -> None:
        super().setup()
        self.example_data = {**self.example_data, **FAULT_KEYS}
        self.dds: Participant | None = None
        self.state: Any = None
        self.t_state = -np.inf

    # -- hardware -----------------------------------------------------------------------------------
    def open(self) -> None:
        c = self.config
        self.dds = Participant(c.domain_id, c.interface)
        try:
            self._state_in = self.dds.reader(self.state_topic)
            self._out = self.dds.writer(self.cmd_topic)
            self.open_topics(self.dds)
            deadline = time.monotonic() + c.connect_timeout_s
            while not self._poll():
                if time.monotonic() > deadline:
                    raise TimeoutError(
                        f"no {self.state_topic} on interface '{c.interface}' (DDS domain {c.domain_id}) within "
                        f"{c.connect_timeout_s} s: is {self.device_hint} on and connected (the G1 powers it), and "
                        "this interface on the robot's network (192.168.123.x)?")
                time.sleep(0.005)
            if not self._out.wait_matched(1.0):
                log.warning("node '%s': nothing reads %s yet: commands may go unheard", self.name, self.cmd_topic)
        except BaseException:
            self.dds.close()
            self.dds = None
            raise

    def close(self) -> None:
        if self.dds is None:
            return
        try:
            if self.config.disable_on_close and self.state is not None:
                t_end = time.monotonic() + 0.05
                while time.monotonic() < t_end:
                    self._send(self.damping())
                    time.sleep(1.0 / self.config.rate_hz)
        finally:
            self.dds.close()
            self.dds = None

    def set_enabled(self, enabled: bool) -> None:
        if enabled:
            self.check_device_fault()
        elif self.dds is not None:
            self._send(self.damping())

    def state_lost(self, age: float) -> Fault:
        c = self.config
        return state_lost("handstate_timeout", self.state_topic, age, f"interface '{c.interface}' (DDS domain "
                          f"{c.domain_id})", "check the hand's cable and the robot")

    # -- cycle --------------------------------------------------------------------------------------
    def read_joints(self) -> dict[str, Any]:
        self._poll()
        self.watch_safety()
        assert self.state is not None
        q, dq = self.joint_state(self.state)
        return {"joint_pos": q, "joint_vel": dq, **self.fault_status()}

    def send_damping(self) -> None:
        if self.dds is not None:
            self._send(self.damping())

    def write_joints(self, joint_pos: np.ndarray) -> None:
        assert self.state is not None
        self._send(self.position(joint_pos, self.joint_state(self.state)[0]))

    # -- helpers ------------------------------------------------------------------------------------
    def _poll(self) -> bool:
        data = self._state_in.latest()
        if data is None:
            return False
        state = self.decode_state(data)
        if state is None:
            return False
        self.state, self.t_state = state, clock.now()
        return True

    def _send(self, cmd: Any) -> None:
        assert self.dds is not None
        self._out.write(cmd.encode())


class Dex3(DdsHand):
    class Config(DdsHand.Config, MotorGainsConfig):
        side: Literal["left", "right"] = Field("right", description="which Dex3-1")
        max_step_rad: float = Field(0.05, gt=0, description="largest joint goal change per cycle (rad): 5 rad/s "
                                                            "at 100 Hz")
        torque_limit: bool = Field(True, description="clip each goal to where kp * error stays within the motor's "
                                                     "effort limit")

    # -- setup --------------------------------------------------------------------------------------
    def default_joint_names(self) -> list[str]:
        return dex3.joint_names(self.config.side)

    def setup(self) -> None:
        super().setup()
        c = self.config
        self.joints = dex3.lookup(c.side, self.joint_list)
        self.ids = np.array([j.index for j in self.joints], dtype=np.intp)
        gains = motor_gains(c, {"kp": [dex3.KP] * self.dof, "kd": [dex3.KD] * self.dof,
                                "damping_kd": [dex3.DAMPING_KD] * self.dof}, self.name, self.dof)
        self.gains = {k: np.asarray(v, np.float64) for k, v in gains.items()}
        self.effort = np.array([j.effort for j in self.joints], np.float64)
        self.device_label = f"the {c.side} Dex3-1 on {c.interface} (DDS domain {c.domain_id})"
        self.device_hint = f"the {c.side} Dex3-1"
        self.state_topic, self.cmd_topic = dex3.state_topic(c.side), dex3.cmd_topic(c.side)

    # -- hardware -----------------------------------------------------------------------------------
    def hardware_limits(self) -> tuple[list[float], list[float]]:
        return [j.lower for j in self.joints], [j.upper for j in self.joints]

    def default_home(self) -> list[float]:
        return [0.0] * self.dof  # open: every Dex3-1 joint's range includes 0

    def robot_description(self) -> dict[str, Any] | None:
        """rio-sim's Dex3-1 of this side (real kinematics from Unitree's URDF), when rio-sim is installed."""
        try:
            from rio_sim import g1 as sim_g1
        except ImportError:
            return None
        side = self.config.side
        return {"format": "mjcf", "xml": sim_g1.hand_xml(side), "joints": list(self.joint_list),
                "keypoints": sim_g1.keypoints(side), "palm": f"{side}_palm", "side": side}

    # -- the commands -----------------------------------------------------------------------------------
    def _cmd(self) -> HandCmd:
        cmd = HandCmd()
        cmd.mode[:] = [dex3.mode_byte(i) for i in range(dex3.NUM_MOTORS)]
        return cmd

    def position(self, goal: np.ndarray, measured: np.ndarray) -> HandCmd:
        """Stiff goal at rest for this node's motors (others of the hand, if any, damped)."""
        lower, upper = self.hardware_limits()
        q = np.clip(goal, lower, upper)
        kp = self.gains["kp"]
        if self.config.torque_limit:
            band = np.where(kp > 0, self.effort / np.maximum(kp, 1e-9), np.inf)
            q = np.clip(q, measured - band, measured + band)
        cmd = self.damping()
        cmd.q[self.ids], cmd.kp[self.ids], cmd.kd[self.ids] = q, kp, self.gains["kd"]
        return cmd

    def damping(self) -> HandCmd:
        """Every motor soft: kp = 0, kd = its damping, no torque."""
        cmd = self._cmd()
        cmd.kd[:] = dex3.DAMPING_KD
        cmd.kd[self.ids] = self.gains["damping_kd"]
        if self.state is not None:
            cmd.q[self.ids] = self.state.q[self.ids]
        return cmd

    def decode_state(self, data: bytes) -> HandState | None:
        state = HandState.decode(data)
        if len(state.q) < dex3.NUM_MOTORS:
            log.warning("node '%s': %s with %d motors (a Dex3-1 has %d): ignored", self.name, self.state_topic,
                        len(state.q), dex3.NUM_MOTORS)
            return None
        return state

    def joint_state(self, state: HandState) -> tuple[np.ndarray, np.ndarray]:
        return state.q[self.ids].astype(np.float64), state.dq[self.ids].astype(np.float64)
