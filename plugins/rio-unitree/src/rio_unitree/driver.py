"""`unitree.g1` (`unitree.g1_23dof`): a Unitree G1 in joint space over its low-level DDS topics.

Each cycle reads the newest `rt/lowstate` (joint positions and velocities, the pelvis IMU) and sends
one command; the humanoid kind owns the targets (interpolation, limits, max step, the watchdog).

Two ways to command, `control`:
- "arm_sdk" (default): waist and arms only, on `rt/arm_sdk`, while Unitree's locomotion keeps the robot
  standing. The message's `motor_cmd[29].q` is the weight with which Unitree's controller takes our
  command over its own (`WEIGHT_SLOT`, the SDK examples' `kNotUsedJoint`); it ramps 0 -> 1 over
  `arm_sdk_ramp_s` on enable and back to 0 on disable, so the arms never jump. The node's joints are
  the upper body's (the legs are not ours to read as commanded joints).
- "lowcmd": the whole body on `rt/lowcmd`. The robot only obeys it with Unitree's locomotion released
  (debug mode: L2+R2 on the remote while it hangs in damping, or the motion switcher's release); the
  robot is then on its own: hang it.

Safety, by the driver itself (each a named fault, `rio.interfaces.damping`, its `DampingGuard` part): no lowstate for
`state_timeout_s` (`lowstate_timeout`); the pelvis tilted beyond `fall_tilt_deg`; and a stream of
commands that stops (the kind's watchdog hold) with `on_stale = "damp"`. A stopped or disabled node in lowcmd mode sends
damping (kp = 0, kd = each joint's damping) every cycle, never a frozen stiff pose; in arm_sdk mode it
hands the arms back to Unitree's controller (weight ramped to 0).

Every command carries the CRC the robot checks, `mode_pr` = 0 (ankles as pitch/roll) and the
`mode_machine` the robot reports (echoed).
"""

from __future__ import annotations

import logging
import time
from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio import clock
from rio.interfaces import BodyDampingConfig, DampingGuard, FaultHolder, HumanoidNode, MotorGainsConfig, motor_gains
from rio.interfaces.damping import state_lost, tilt_from_quat

from . import g1
from .commands import Commands
from .dds import ARM_SDK, LOWCMD, LOWSTATE, DdsConfig, Participant
from .wire import LowState, state_signature

log = logging.getLogger("rio_unitree")


class G1(HumanoidNode):
    class Config(DdsConfig, BodyDampingConfig, MotorGainsConfig, HumanoidNode.Config):
        defaults = {"max_step_rad": 0.004}  # 2 rad/s at 500 Hz
        dof: Literal[23, 29] = Field(29, description="which G1: 29 joints, or 23 (no waist roll/pitch, no wrist "
                                                     "pitch/yaw)")
        control: Literal["arm_sdk", "lowcmd"] = Field(
            "arm_sdk", description='"arm_sdk": waist and arms on rt/arm_sdk while Unitree\'s locomotion stands the '
                                   'robot; "lowcmd": whole body on rt/lowcmd (debug mode only: hang the robot)')
        torque_limit: bool = Field(True, description="clip each goal to where kp * error stays within the motor's "
                                                     "effort limit")
        arm_sdk_ramp_s: float = Field(1.0, gt=0, description="arm_sdk: seconds to ramp the weight 0 -> 1 (enable) "
                                                             "and 1 -> 0 (disable)")
        peer: Literal["robot", "simulator"] = Field(
            "robot", description='who publishes rt/lowstate: "robot" (every state must carry its CRC) or '
                                 '"simulator" (Unitree\'s unitree_mujoco: unsigned state, CRC 0, is accepted too; a '
                                 'wrong CRC never is)')
        renamed = {"check_state_crc": "peer"}
        renamed_values = {"peer": {True: "robot", False: "simulator"}}

    # -- setup --------------------------------------------------------------------------------------
    def default_joint_names(self) -> list[str]:
        return g1.joint_names(self.config.dof, upper_body_only=self.config.control == "arm_sdk")

    def setup(self) -> None:
        super().setup()
        c = self.config
        self.joints = g1.lookup(self.joint_list)
        self.wire_slots = np.array([j.slot for j in self.joints], dtype=np.intp)  # motor slot of each joint
        missing = set(g1.joint_names(29)) - set(g1.joint_names(c.dof))
        bad = [j.name for j in self.joints if j.name in missing]
        if bad:
            raise ValueError(f"the {c.dof}-DoF G1 has no joints {bad}")
        if c.control == "arm_sdk":
            legs = [j.name for j in self.joints if j.slot not in g1.UPPER_BODY_SLOTS]
            if legs:
                raise ValueError(f"control = 'arm_sdk' drives the waist and arms only; {legs} belong to Unitree's "
                                 "locomotion (use control = 'lowcmd' for the whole body)")
        self.gains = motor_gains(c, {"kp": [j.kp for j in self.joints], "kd": [j.kd for j in self.joints],
                                     "damping_kd": [j.damping for j in self.joints]}, self.name, self.dof)
        self.safety = DampingGuard(self, self.state_lost, tilt=self.tilt_deg, body="pelvis")
        self.faults = FaultHolder(self, f"the G1 on {c.interface} (DDS domain {c.domain_id})",
                                  ask=self.safety.device_fault)
        self.dds: Participant | None = None
        self.state: LowState | None = None
        self.bad_crc = 0  # states refused: a wrong CRC, or unsigned from a peer that should sign
        self.unsigned = 0  # of those, unsigned (CRC 0: a simulator)
        self._weight = 0.0  # arm_sdk weight last sent
        self._t_sent = 0.0
        self._goal: np.ndarray | None = None  # last goal sent (held while the arm_sdk weight ramps down)

    # -- hardware -----------------------------------------------------------------------------------
    def open(self) -> None:
        c = self.config
        self.dds = Participant(c.domain_id, c.interface)
        try:
            self._state_in = self.dds.reader(LOWSTATE)
            self._out = self.dds.writer(ARM_SDK if c.control == "arm_sdk" else LOWCMD)
            deadline = time.monotonic() + c.connect_timeout_s
            while not self._poll():
                if time.monotonic() > deadline:
                    raise TimeoutError(
                        f"no rt/lowstate on interface '{c.interface}' (DDS domain {c.domain_id}) within "
                        f"{c.connect_timeout_s} s{self._refused()}: is the robot on, and this interface on its "
                        f"network (192.168.123.x)? `rio unitree check --interface {c.interface} --domain-id "
                        f"{c.domain_id}` tells (a simulator: its interface and domain, unitree_mujoco's are lo and 1)")
                if self.exit_event.wait(0.005):  # the station stops (another node failed): stop waiting
                    raise ConnectionAbortedError(f"stopped while waiting for rt/lowstate on '{c.interface}'")
            if not self._out.wait_matched(max(1.0, c.connect_timeout_s) if c.control == "arm_sdk" else 1.0):
                if c.control == "arm_sdk":  # commands nobody reads: the run would end "normally", arms never moved
                    raise ConnectionError(
                        f"nothing reads rt/arm_sdk on '{c.interface}' (DDS domain {c.domain_id}): on the robot "
                        "Unitree's locomotion service does; a simulator such as unitree_mujoco listens on rt/lowcmd "
                        "only: set control = \"lowcmd\" for it")
                log.warning("node '%s': nothing reads %s on %s (domain %d) yet: commands may go unheard", self.name,
                            self._out.topic, c.interface, c.domain_id)
        except BaseException:
            self.dds.close()
            self.dds = None
            raise
        lower, upper = self.hardware_limits()
        self.wire = Commands(self.joints, self.gains["kp"], self.gains["kd"], self.gains["damping_kd"],
                             np.array(lower), np.array(upper), c.torque_limit, c.dof)

    def close(self) -> None:
        if self.dds is None:
            return
        try:
            if self.config.disable_on_close:
                self._settle_before_close()
        finally:
            self.dds.close()
            self.dds = None

    def hardware_limits(self) -> tuple[list[float], list[float]]:
        return [j.lower for j in self.joints], [j.upper for j in self.joints]

    def default_home(self) -> list[float]:
        return [g1.HOME.get(j.name, 0.0) for j in self.joints]

    def robot_description(self) -> dict[str, Any] | None:
        """rio-sim's G1 (built from Unitree's URDF: the real kinematics) with its wrist sites as IK frames,
        when rio-sim is installed; None otherwise (the plugin's own bridge model is only G1-like)."""
        from .bridge.model import rio_sim_asset

        path = rio_sim_asset()
        xml = path.read_text(encoding="utf-8") if path is not None else ""
        if 'name="left_wrist"' not in xml or 'name="right_wrist"' not in xml:
            return None
        return {"format": "mjcf", "xml": xml, "joints": list(self.joint_list),
                "frames": {"left": "left_wrist", "right": "right_wrist"}, "frame_type": "site",
                "home": self.default_home()}

    def set_enabled(self, enabled: bool) -> None:
        if enabled:
            self._goal = None
            self._t_sent = clock.now()
        elif self.config.control == "lowcmd" and self.dds is not None:
            self._send(self.wire.damping(self._mode_machine()))

    def state_lost(self, age: float) -> Any:
        c = self.config
        return state_lost("lowstate_timeout", "rt/lowstate", age, f"interface '{c.interface}' (DDS domain "
                          f"{c.domain_id})", "check the cable, the interface's address (192.168.123.x) and that "
                          "the robot is on")

    def tilt_deg(self) -> float | None:
        return None if self.state is None else tilt_from_quat(self.state.quaternion)

    # -- cycle --------------------------------------------------------------------------------------
    def read_joints(self) -> dict[str, Any]:
        self._poll()
        self.safety.watch()
        s, idx = self.state, self.wire_slots
        assert s is not None
        quat = np.asarray(s.quaternion, np.float64)
        norm = float(np.linalg.norm(quat))
        return {"joint_pos": s.q[idx].astype(np.float64), "joint_vel": s.dq[idx].astype(np.float64),
                "base_quat": quat / norm if norm > 0.5 else np.full(4, np.nan),
                "base_ang_vel": np.asarray(s.gyroscope, np.float64)}

    def write_joints(self, joint_pos: np.ndarray) -> None:
        s = self.state
        assert s is not None
        now = clock.now()
        self._goal = joint_pos.copy()
        measured = s.q[self.wire_slots].astype(np.float64)
        weight = None
        if self.config.control == "arm_sdk":
            self._weight = min(1.0, self._weight + (now - self._t_sent) / self.config.arm_sdk_ramp_s)
            weight = self._weight
        self._t_sent = now
        self._send(self.wire.position(joint_pos, measured, self._mode_machine(), weight))

    # -- helpers ------------------------------------------------------------------------------------
    def _mode_machine(self) -> int:
        return self.state.mode_machine if self.state is not None else 0

    def _poll(self) -> bool:
        """Take the newest lowstate its peer signs as it should; whether one came."""
        got = False
        trusted = ("signed", "unsigned") if self.config.peer == "simulator" else ("signed",)
        for data in reversed(self._state_in.take()):
            signature = state_signature(data)
            if signature in trusted:
                self.state, self.safety.t_state, got = LowState.decode(data), clock.now(), True
                break
            self.bad_crc += 1
            self.unsigned += signature == "unsigned"
        return got

    def _refused(self) -> str:
        """Why states that came were not believed, for the error that no state came."""
        if not self.bad_crc:
            return ""
        if self.unsigned == self.bad_crc:
            return (f" ({self.unsigned} arrived unsigned, CRC 0, as a simulator such as unitree_mujoco publishes: "
                    "set peer = \"simulator\" for it)")
        return f" ({self.bad_crc} arrived with a wrong CRC, {self.unsigned} of them unsigned)"

    def _send(self, cmd: Any) -> None:
        assert self.dds is not None
        self._out.write(cmd.encode())

    def write_disabled(self) -> None:
        """While disabled (or stopped): damping on rt/lowcmd; on rt/arm_sdk, the weight ramped down to 0
        holding the last goal, then silence (Unitree's controller has the arms)."""
        if self.dds is None or self.state is None:
            return
        if self.config.control == "lowcmd":
            self._send(self.wire.damping(self._mode_machine()))
            return
        if self._weight <= 0.0 and self._goal is None:
            return
        now = clock.now()
        self._weight = max(0.0, self._weight - (now - self._t_sent) / self.config.arm_sdk_ramp_s)
        self._t_sent = now
        goal = self._goal if self._goal is not None else self.state.q[self.wire_slots].astype(np.float64)
        measured = self.state.q[self.wire_slots].astype(np.float64)
        self._send(self.wire.position(goal, measured, self._mode_machine(), self._weight))
        if self._weight <= 0.0:
            self._goal = None

    def _settle_before_close(self) -> None:
        """The loop has stopped: finish the arm_sdk ramp-down (or send damping a moment) before the
        participant goes, so the robot's last command from us is a safe one."""
        period = 1.0 / self.config.rate_hz
        t_end = time.monotonic() + (self.config.arm_sdk_ramp_s + 0.1 if self.config.control == "arm_sdk" else 0.05)
        while time.monotonic() < t_end:
            self._poll()
            self.write_disabled()
            if self.config.control == "arm_sdk" and self._goal is None:
                break
            time.sleep(period)
