"""Unitree's DDS hands in joint space: `HandTopics`, the part every one holds for its state/command topic
pair, `HandConfig`, and `unitree.dex3`, one Dex3-1 hand (config `side`) on its own topics (`unitree.inspire`:
`inspire.py`).

`HandTopics` opens one participant, a reader of the hand's state topic and a writer of its command topic,
waits for the first state at open, and sends what the node gives it: the driver's `position(goal,
measured)` each cycle while enabled, its `damping()` while disabled or faulted and a moment before closing.

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
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio import clock
from rio.interfaces import DampingConfig, DampingGuard, Fault, FaultHolder, HandNode, MotorGainsConfig, motor_gains
from rio.interfaces.damping import state_lost

from . import dex3
from .dds import DdsConfig, Participant
from .hand_wire import HandCmd, HandState

log = logging.getLogger("rio_unitree")

class HandConfig(DdsConfig, DampingConfig, HandNode.Config):
    """Station fields of every Unitree DDS hand."""

    defaults = {"rate_hz": 100.0, "max_step_rad": 0.05}  # 5 rad/s at 100 Hz


def hand_parts(node: Any, device: str, topic: str) -> None:
    """Give a hand node its damping guard and fault holder (`device`: what the log calls it; `topic`: its
    state topic, which the lost-state fault names)."""
    c = node.config

    def lost(age: float) -> Fault:
        return state_lost("handstate_timeout", topic, age, f"interface '{c.interface}' (DDS domain {c.domain_id})",
                          "check the hand's cable and the robot")

    node.safety = DampingGuard(node, lost, device_noun="hand")
    node.faults = FaultHolder(node, device, ask=node.safety.device_fault)


class HandTopics:
    """A hand's state and command topics on one DDS participant (`dds`, None while closed). `decode(bytes)`:
    the hand's state, or None when a message is not this hand's; `hint`: what open()'s timeout asks about
    ("the left Dex3-1"); `guard`: the node's damping guard, told when a state arrives."""

    def __init__(self, state_topic: str, cmd_topic: str, decode: Callable[[bytes], Any], hint: str,
                 guard: DampingGuard):
        self.state_topic, self.cmd_topic, self.decode, self.hint, self.guard = (state_topic, cmd_topic, decode,
                                                                                hint, guard)
        self.dds: Participant | None = None
        self.state: Any = None  # the newest state

    def open(self, config: Any, more: Callable[[Participant], None] | None = None) -> Participant:
        """Join the domain, open both topics (and `more` of the driver's), wait for the first state."""
        c = config
        self.dds = Participant(c.domain_id, c.interface)
        try:
            self._state_in = self.dds.reader(self.state_topic)
            self._out = self.dds.writer(self.cmd_topic)
            if more is not None:
                more(self.dds)
            deadline = time.monotonic() + c.connect_timeout_s
            while not self.poll():
                if time.monotonic() > deadline:
                    raise TimeoutError(
                        f"no {self.state_topic} on interface '{c.interface}' (DDS domain {c.domain_id}) within "
                        f"{c.connect_timeout_s} s: is {self.hint} on and connected (the G1 powers it), and "
                        "this interface on the robot's network (192.168.123.x)?")
                time.sleep(0.005)
            if not self._out.wait_matched(1.0):
                log.warning("%s: nothing reads %s yet: commands may go unheard", self.hint, self.cmd_topic)
        except BaseException:
            self.dds.close()
            self.dds = None
            raise
        return self.dds

    def close(self, damping: Callable[[], Any] | None, rate_hz: float) -> None:
        """Leave the domain; with `damping`, send it a moment first (the hand's last command from us is soft)."""
        if self.dds is None:
            return
        try:
            if damping is not None and self.state is not None:
                t_end = time.monotonic() + 0.05
                while time.monotonic() < t_end:
                    self.send(damping())
                    time.sleep(1.0 / rate_hz)
        finally:
            self.dds.close()
            self.dds = None

    def poll(self) -> bool:
        """Take the newest state; whether one came."""
        data = self._state_in.latest()
        if data is None:
            return False
        state = self.decode(data)
        if state is None:
            return False
        self.state, self.guard.t_state = state, clock.now()
        return True

    def send(self, cmd: Any) -> None:
        if self.dds is not None:
            self._out.write(cmd.encode())


class Dex3(HandNode):
    class Config(HandConfig, MotorGainsConfig):
        side: Literal["left", "right"] = Field("right", description="which Dex3-1")
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
        hand_parts(self, f"the {c.side} Dex3-1 on {c.interface} (DDS domain {c.domain_id})", dex3.state_topic(c.side))
        self.topics = HandTopics(dex3.state_topic(c.side), dex3.cmd_topic(c.side), self.decode_state,
                                 f"the {c.side} Dex3-1", self.safety)

    # -- hardware -----------------------------------------------------------------------------------
    def open(self) -> None:
        self.topics.open(self.config)

    def close(self) -> None:
        self.topics.close(self.damping if self.config.disable_on_close else None, self.config.rate_hz)

    def set_enabled(self, enabled: bool) -> None:
        if not enabled:
            self.topics.send(self.damping())

    def read_joints(self) -> dict[str, Any]:
        self.topics.poll()
        self.safety.watch()
        q, dq = self.joint_state(self.topics.state)
        return {"joint_pos": q, "joint_vel": dq}

    def write_joints(self, joint_pos: np.ndarray) -> None:
        self.topics.send(self.position(joint_pos, self.joint_state(self.topics.state)[0]))

    def write_disabled(self) -> None:
        self.topics.send(self.damping())

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
        if self.topics.state is not None:
            cmd.q[self.ids] = self.topics.state.q[self.ids]
        return cmd

    def decode_state(self, data: bytes) -> HandState | None:
        state = HandState.decode(data)
        if len(state.q) < dex3.NUM_MOTORS:
            log.warning("node '%s': %s with %d motors (a Dex3-1 has %d): ignored", self.name, self.topics.state_topic,
                        len(state.q), dex3.NUM_MOTORS)
            return None
        return state

    def joint_state(self, state: HandState) -> tuple[np.ndarray, np.ndarray]:
        return state.q[self.ids].astype(np.float64), state.dq[self.ids].astype(np.float64)
