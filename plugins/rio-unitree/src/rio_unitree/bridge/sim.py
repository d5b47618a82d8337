"""The bridge: a simulated G1 that speaks the robot's own DDS topics (the role of Unitree's
unitree_mujoco), so the unmodified driver, Unitree's SDK examples or any DDS tool run against physics.

One thread steps MuJoCo in real time at the model's timestep (500 Hz for the G1 models) and, as the
robot does:
- takes `rt/lowcmd` and `rt/arm_sdk`, checks each one's CRC (a bad one is counted and ignored);
- drives each motor with tau = kp (q* - q) + kd (dq* - dq) + tau_ff, clipped to its effort limit
  (inside MuJoCo's step: `model.load`), from the last valid lowcmd (a motor whose `mode` is 0 is off);
  until a lowcmd arrives it holds the start pose (`stand_in`: the part Unitree's locomotion plays on a
  real G1, with the stiff gains Unitree's xr_teleoperate holds a G1 with: 300/3 hips, knees and waist,
  80/3 ankles and arms, 40/1.5 wrists);
- blends rt/arm_sdk in on the waist and arms: tau = (1 - w) tau_lowcmd + w tau_arm_sdk, w =
  motor_cmd[29].q clipped to [0, 1] (the arm_sdk message's `mode` bytes are not needed: Unitree's
  example leaves them 0);
- publishes `rt/lowstate` (CRC set) at `state_rate_hz`: each motor's q, dq, ddq and applied torque, the
  pelvis IMU (quaternion wxyz, gyroscope in the body frame, accelerometer as gravity in the body frame,
  rpy) and `mode_machine`.

With a model that has the Dex3-1 hands (`model = "hands"`: rio-sim's G1 with hands), it also plays both
hands: takes `rt/dex3/<side>/cmd` (each motor driven by the same law when its mode byte's status is
non-zero and its id is its index; a motor whose id is wrong is off and counted in `counts.bad_hand_id`;
no command yet: the hand is limp) and publishes `rt/dex3/<side>/state` at `hand_state_rate_hz`.
With `hands = "inspire"` it plays the G1's two Inspire hands as Unitree's Inspire service shows them
(`rt/inspire/cmd`, `rt/inspire/state` at `hand_state_rate_hz`): emulated servos, no physics (`inspire.py`).

And it answers Unitree's motion switcher RPC (`rt/api/motion_switcher/request`): CheckMode says
`{"name": "ai", ...}` while the stand-in (its locomotion) holds the robot; ReleaseMode releases it (the
stand-in goes soft: damping, as a released G1 does) and CheckMode says `{"name": ""}` from then on.

With a free base (`mounted=False`) and `gantry=True`, a gantry holds the pelvis up from the start until
it is released and lowered (`gantry.py`): `release_gantry()`, or `release_after_s` seconds after the legs
are first commanded stiff on rt/lowcmd.

A lagging machine slows the simulation instead of bursting steps to catch up. The states go out from a
thread of their own at their rates on the wall clock, the physics' latest each time, as a robot's stream
does whatever its host is doing: published by the physics thread at simulated times, a host too loaded to
run the physics in real time left gaps of up to 0.9 s in the Dex3 hands' state (and 0.6 s in rt/lowstate),
which their drivers rightly took for a lost device.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rio.control.rotations import quat_to_euler

from .. import dex3
from ..dds import (
    ARM_SDK,
    INSPIRE_CMD,
    INSPIRE_STATE,
    LOWCMD,
    LOWSTATE,
    MOTION_SWITCHER_REQUEST,
    MOTION_SWITCHER_RESPONSE,
    Participant,
)
from ..g1 import HOME, JOINTS, NUM_SLOTS, UPPER_BODY_SLOTS, WEIGHT_SLOT
from ..hand_wire import HandCmd, HandState
from ..inspire_wire import MotorCmds
from ..wire import LowCmd, LowState, cmd_crc_ok
from .gantry import Gantry
from .inspire import InspirePair
from .model import G1Model, load

log = logging.getLogger("rio_unitree.bridge")

_MAX_LAG_S = 0.05  # behind the wall clock by more than this: give the time up


@dataclass
class Counts:
    lowcmd: int = 0
    arm_sdk: int = 0
    bad_crc: int = 0
    malformed: int = 0
    lowstate: int = 0
    steps: int = 0
    hand_cmd: int = 0
    hand_state: int = 0
    bad_hand_id: int = 0
    rpc: int = 0


class Bridge:
    """`with Bridge(domain_id=..., interface="lo") as b:` runs it until the block ends (or `start()` /
    `stop()`). `model`: an MJCF path, "fallback", or None (rio-sim's G1 when installed, else the
    fallback); `mounted`: pelvis welded to the world; `gantry` (free base only): held up until released
    (`release_after_s` after the legs are first commanded stiff, or `release_gantry()`), then lowered
    over `lower_s`. `hands = "inspire"`: also the G1's two Inspire hands (`inspire.py`)."""

    def __init__(self, domain_id: int = 0, interface: str = "lo", model: str | Path | None = None,
                 mounted: bool = True, state_rate_hz: float = 500.0, mode_machine: int = 5,
                 stand_in: bool = True, start_pose: dict[str, float] | None = None,
                 hand_state_rate_hz: float = 100.0, gantry: bool = False, release_after_s: float | None = None,
                 lower_s: float = 2.0, hands: str | None = None):
        self.domain_id, self.interface = domain_id, interface
        if hands not in (None, "inspire"):
            raise ValueError(f'hands: "inspire" (emulated Inspire hands) or unset, not {hands!r} (the Dex3-1 '
                             'hands come with model = "hands")')
        if gantry and mounted:
            raise ValueError("gantry: it holds a free-floating G1 (mounted = false); a mounted one is welded already")
        if release_after_s is not None and not gantry:
            raise ValueError("release_after_s releases the gantry: set gantry = true (and mounted = false)")
        self.sim: G1Model = load(model, mounted)
        if gantry and not self.sim.free:
            raise ValueError(f"gantry: {self.sim.source} has no free joint on its pelvis to hold")
        if hands == "inspire" and self.sim.hands:
            raise ValueError(f"hands = 'inspire': {self.sim.source} has Dex3-1 hands already; a G1 wears one kind")
        self.inspire = InspirePair() if hands == "inspire" else None
        self.hand_state_period = 1.0 / hand_state_rate_hz
        self.hand_cmd: dict[str, HandCmd | None] = {side: None for side in self.sim.hands}
        self.released = False  # the motion switcher released the stand-in (its "locomotion")
        self.dt = float(self.sim.model.opt.timestep)
        self.state_period = 1.0 / state_rate_hz
        self.mode_machine = mode_machine
        self.counts = Counts()
        self.lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._publisher: threading.Thread | None = None
        #: the physics' latest states (lowstate, Dex3 states by side, Inspire state), for the publisher
        self._latest: tuple[LowState, dict[str, HandState], Any] | None = None
        self.dds: Participant | None = None
        n = len(self.sim.slots)
        pose = HOME if start_pose is None else start_pose
        unknown = sorted(set(pose) - {j.name for j in JOINTS})
        if unknown:
            raise ValueError(f"start_pose: unknown G1 joints {unknown}")
        by_slot = {j.slot: j for j in JOINTS}
        self.start_q = np.array([pose.get(by_slot[s].name, 0.0) for s in self.sim.slots])
        kp, kd = zip(*(_stand_in_gains(by_slot[s].name) for s in self.sim.slots), strict=True)
        self._hold = self._command(self.start_q, kp, kd, enabled=stand_in)
        self.lowcmd: LowCmd | None = None  # the last valid one
        self.arm_sdk: LowCmd | None = None
        self.tau = np.zeros(n)  # each motor's torque in the last step
        self._upper = np.array([s in UPPER_BODY_SLOTS for s in self.sim.slots])
        self._mode_pr = 0
        self._legs = np.array([s < 12 for s in self.sim.slots])  # leg motors: slots 0-11
        self.gantry: Gantry | None = None
        if gantry:
            m = self.sim.model
            jnt = int(m.body_jntadr[self.sim.pelvis])
            self.gantry = Gantry(m, self.sim.data, self.sim.pelvis, int(m.jnt_qposadr[jnt]), int(m.jnt_dofadr[jnt]),
                                 release_after_s=release_after_s, lower_s=lower_s)
        self.reset()

    # -- lifecycle ------------------------------------------------------------------------------------
    def start(self) -> Bridge:
        self.dds = Participant(self.domain_id, self.interface)
        try:
            self._cmd_in = self.dds.reader(LOWCMD, depth=32)
            self._arm_in = self.dds.reader(ARM_SDK, depth=32)
            self._state_out = self.dds.writer(LOWSTATE)
            self._hand_io = {side: (self.dds.reader(dex3.cmd_topic(side), depth=8),
                                    self.dds.writer(dex3.state_topic(side))) for side in self.sim.hands}
            if self.inspire is not None:
                self._inspire_io = (self.dds.reader(INSPIRE_CMD, depth=8), self.dds.writer(INSPIRE_STATE))
            self._rpc_in = self.dds.reader(MOTION_SWITCHER_REQUEST, depth=8)
            self._rpc_out = self.dds.writer(MOTION_SWITCHER_RESPONSE)
        except BaseException:
            self.dds.close()
            raise
        self._stop.clear()
        self._latest = None
        self._thread = threading.Thread(target=self._run, name="g1-sim", daemon=True)
        self._publisher = threading.Thread(target=self._publish_loop, name="g1-sim-state", daemon=True)
        self._thread.start()
        self._publisher.start()
        hands = "Inspire (emulated)" if self.inspire is not None else sorted(self.sim.hands) or "none"
        log.info("G1 bridge on %s, DDS domain %d: %s, %d joints, hands %s, %.0f Hz physics", self.interface,
                 self.domain_id, self.sim.source, len(self.sim.slots), hands, 1.0 / self.dt)
        return self

    def stop(self) -> None:
        self._stop.set()
        for thread in (self._thread, self._publisher):
            if thread is not None:
                thread.join(timeout=5.0)
        self._thread = self._publisher = None
        if self.dds is not None:
            self.dds.close()
            self.dds = None

    def __enter__(self) -> Bridge:
        return self.start()

    def __exit__(self, *exc: Any) -> None:
        self.stop()

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    # -- what tests and tools reach in for ---------------------------------------------------------------
    def reset(self) -> None:
        """Back to the start pose, at rest (the commands received stay)."""
        import mujoco

        with self.lock:
            m, d = self.sim.model, self.sim.data
            mujoco.mj_resetData(m, d)
            d.qpos[self.sim.qpos] = self.start_q
            mujoco.mj_forward(m, d)
            if self.gantry is not None:
                self.gantry.engage()

    def release_gantry(self) -> None:
        """Lower the gantry now (over `lower_s`): the feet take the robot's weight."""
        if self.gantry is None:
            raise ValueError("this bridge has no gantry (gantry = true, with a free base)")
        with self.lock:
            self.gantry.release()

    def base_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Ground truth: the pelvis' position (m, world) and orientation (quaternion wxyz)."""
        with self.lock:
            d = self.sim.data
            return d.xpos[self.sim.pelvis].copy(), d.xquat[self.sim.pelvis].copy()

    def joint_pos(self) -> np.ndarray:
        """Ground truth, in motor-slot order of the model's joints."""
        with self.lock:
            return self.sim.data.qpos[self.sim.qpos].copy()

    def hand_pos(self, side: str) -> np.ndarray:
        """Ground truth of a Dex3-1's joints, in its motor order."""
        with self.lock:
            return self.sim.data.qpos[self.sim.hands[side].qpos].copy()

    def inspire_pos(self) -> np.ndarray:
        """Ground truth of the emulated Inspire hands: 12 positions in the service's units (1 open)."""
        if self.inspire is None:
            raise ValueError("this bridge plays no Inspire hands (hands = \"inspire\")")
        with self.lock:
            return self.inspire.q.copy()

    def set_base_orientation(self, quat_wxyz: Any) -> None:
        """Turn the whole robot (tilt its mount, or set a free pelvis' orientation): what a fall looks
        like to the IMU, on a model that cannot fall."""
        import mujoco

        q = np.asarray(quat_wxyz, np.float64)
        q = q / np.linalg.norm(q)
        with self.lock:
            m, d = self.sim.model, self.sim.data
            if self.sim.free:
                d.qpos[3:7] = q
            else:
                m.body_quat[self.sim.pelvis] = q
            mujoco.mj_forward(m, d)

    def tilt(self, degrees: float, axis: str = "y") -> None:
        """Tilt the robot about the world's x or y axis (a fall forward is +y)."""
        half = math.radians(degrees) / 2.0
        v = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0)}[axis]
        self.set_base_orientation([math.cos(half), *(math.sin(half) * np.array(v))])

    # -- the loop -------------------------------------------------------------------------------------------
    def _run(self) -> None:
        """The physics, in real time at the model's timestep (behind by more than `_MAX_LAG_S`: the time is
        given up), and after each round of steps the states the publisher sends."""
        t0, steps = time.monotonic(), 0
        try:
            while not self._stop.is_set():
                self._take_commands()
                self._answer_rpc()
                due = int((time.monotonic() - t0) / self.dt)
                if due - steps > _MAX_LAG_S / self.dt:
                    t0 += (due - steps - 1) * self.dt
                    due = steps + 1
                with self.lock:
                    while steps < due:
                        self._step()
                        steps += 1
                    self._latest = (self._lowstate(), self._hand_states() if self.sim.hands else {},
                                    self.inspire.state() if self.inspire is not None else None)
                time.sleep(max(0.0, t0 + (steps + 1) * self.dt - time.monotonic()))
        except Exception:  # a bridge that dies says so; the driver's lowstate timeout does the rest
            log.exception("G1 bridge stopped")
            raise

    def _publish_loop(self) -> None:
        """rt/lowstate at `state_rate_hz` and the hands' states at `hand_state_rate_hz` on the wall clock:
        the physics' latest each time. A late slot is not made up for (the next is the next after now)."""
        next_state = next_hand = time.monotonic()
        try:
            while not self._stop.is_set():
                latest, now = self._latest, time.monotonic()
                if latest is not None and now >= next_state:
                    self._state_out.write(latest[0].encode())
                    self.counts.lowstate += 1
                    next_state = _next_slot(next_state, self.state_period, now)
                if latest is not None and now >= next_hand:
                    for side, hand_state in latest[1].items():
                        self._hand_io[side][1].write(hand_state.encode())
                        self.counts.hand_state += 1
                    if latest[2] is not None:
                        self._inspire_io[1].write(latest[2].encode())
                        self.counts.hand_state += 1
                    next_hand = _next_slot(next_hand, self.hand_state_period, now)
                self._stop.wait(max(0.0, min(next_state, next_hand) - time.monotonic()) if latest else 0.001)
        except Exception:
            log.exception("G1 bridge: publishing the state stopped")
            raise

    def _take_commands(self) -> None:
        for reader, topic in ((self._cmd_in, LOWCMD), (self._arm_in, ARM_SDK)):
            for data in reader.take():
                try:
                    ok = cmd_crc_ok(data)
                except ValueError:
                    self.counts.malformed += 1
                    continue
                if not ok:
                    self.counts.bad_crc += 1
                    continue
                cmd = LowCmd.decode(data)
                if topic == LOWCMD:
                    self.lowcmd, self._mode_pr = cmd, cmd.mode_pr
                    self.counts.lowcmd += 1
                else:
                    self.arm_sdk = cmd
                    self.counts.arm_sdk += 1
        for side, (reader, _) in self._hand_io.items():
            for data in reader.take():
                try:
                    self.hand_cmd[side] = HandCmd.decode(data)
                except Exception:
                    self.counts.malformed += 1
                    continue
                self.counts.hand_cmd += 1
        if self.inspire is not None:
            self._take_inspire()

    def _take_inspire(self) -> None:
        assert self.inspire is not None
        for data in self._inspire_io[0].take():
            try:
                ok = self.inspire.command(MotorCmds.decode(data))
            except Exception:
                ok = False
            if not ok:
                self.counts.malformed += 1
                continue
            self.counts.hand_cmd += 1

    def _answer_rpc(self) -> None:
        """Unitree's motion switcher, as far as releasing the locomotion goes (module docstring)."""
        requests = self._rpc_in.take()
        if not requests:
            return
        import json

        from unitree_sdk2py.idl.unitree_api.msg.dds_ import Request_, Response_, ResponseHeader_, ResponseStatus_

        from ..motion_switcher import CHECK_MODE, RELEASE_MODE

        for data in requests:
            try:
                req = Request_.deserialize(data)
            except Exception:
                self.counts.malformed += 1
                continue
            self.counts.rpc += 1
            api, code, out = req.header.identity.api_id, 0, ""
            if api == CHECK_MODE:
                out = json.dumps({"form": "0", "name": "" if self.released else "ai"})
            elif api == RELEASE_MODE:
                with self.lock:
                    self.released = True
                    self._hold = self._command(self.start_q, np.zeros(len(self.start_q)),
                                               [j.damping for j in JOINTS if j.slot in set(self.sim.slots.tolist())])
            else:
                code = 3203  # RPC_ERR_SERVER_API_NOT_IMPL
            if not req.header.policy.noreply:
                self._rpc_out.write(Response_(ResponseHeader_(req.header.identity, ResponseStatus_(code)), out,
                                              []).serialize())

    def _command(self, q: Any, kp: Any, kd: Any, enabled: bool = True) -> LowCmd:
        cmd = LowCmd()
        s = self.sim.slots
        cmd.mode[s] = 1 if enabled else 0
        cmd.q[s], cmd.kp[s], cmd.kd[s] = q, kp, kd
        return cmd

    def _terms(self, cmd: LowCmd, weight: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One command's share of each motor's affine law, scaled by `weight`: (ctrl, kp, kd) with
        force = ctrl - kp q - kd dq = kp (q* - q) + kd (dq* - dq) + tau_ff."""
        s = self.sim.slots
        kp, kd = cmd.kp[s].astype(np.float64) * weight, cmd.kd[s].astype(np.float64) * weight
        ctrl = kp * cmd.q[s] + kd * cmd.dq[s] + weight * cmd.tau[s]
        return ctrl, kp, kd

    def _step(self) -> None:
        import mujoco

        m, d, sim = self.sim.model, self.sim.data, self.sim
        base = self.lowcmd or self._hold
        w_base = (base.mode[sim.slots] != 0).astype(np.float64)  # a motor with mode 0 is off
        w_arm = np.zeros(len(sim.slots))
        if self.arm_sdk is not None:
            w = float(np.clip(self.arm_sdk.q[WEIGHT_SLOT], 0.0, 1.0))
            w_arm = np.where(self._upper, w, 0.0)
        ctrl, kp, kd = self._terms(base, w_base * (1.0 - w_arm))
        if w_arm.any():
            c2, kp2, kd2 = self._terms(self.arm_sdk, w_arm)
            ctrl, kp, kd = ctrl + c2, kp + kp2, kd + kd2
        d.ctrl[sim.act] = ctrl
        m.actuator_biasprm[sim.act, 1] = -kp
        m.actuator_biasprm[sim.act, 2] = -kd
        for side, hand in sim.hands.items():
            self._drive_hand(hand, self.hand_cmd[side])
        if self.inspire is not None:
            self.inspire.step(self.dt)
        if self.gantry is not None:
            if self.lowcmd is not None and np.all((kp > 0)[self._legs]):
                self.gantry.legs_stiff()
            self.gantry.apply()
        mujoco.mj_step(m, d)
        self.tau = d.actuator_force[sim.act].copy()
        self.counts.steps += 1

    def _drive_hand(self, hand: Any, cmd: HandCmd | None) -> None:
        m, d = self.sim.model, self.sim.data
        if cmd is None or len(cmd.q) < dex3.NUM_MOTORS:  # limp until commanded
            d.ctrl[hand.act] = 0.0
            m.actuator_biasprm[hand.act, 1:3] = 0.0
            return
        n = dex3.NUM_MOTORS
        motor_id, status = cmd.mode[:n] & 0x0F, (cmd.mode[:n] >> 4) & 0x07
        wrong = (status != 0) & (motor_id != np.arange(n))
        if wrong.any():
            self.counts.bad_hand_id += 1
        on = ((status != 0) & ~wrong).astype(np.float64)
        kp, kd = cmd.kp[:n] * on, cmd.kd[:n] * on
        d.ctrl[hand.act] = kp * cmd.q[:n] + kd * cmd.dq[:n] + on * cmd.tau[:n]
        m.actuator_biasprm[hand.act, 1] = -kp
        m.actuator_biasprm[hand.act, 2] = -kd

    def _hand_states(self) -> dict[str, HandState]:
        d, out = self.sim.data, {}
        for side, hand in self.sim.hands.items():
            st = HandState()
            cmd = self.hand_cmd[side]
            st.mode[:] = cmd.mode[:dex3.NUM_MOTORS] if cmd is not None and len(cmd.mode) >= dex3.NUM_MOTORS else 0
            st.q[:], st.dq[:], st.ddq[:] = d.qpos[hand.qpos], d.qvel[hand.dof], d.qacc[hand.dof]
            st.tau_est[:] = d.actuator_force[hand.act]
            st.temperature[:] = 30
            st.vol[:] = 24.0
            st.power[:] = (24.0, 0.5, 24.0, 5.0)
            out[side] = st
        return out

    def _lowstate(self) -> LowState:
        import mujoco

        m, d, sim = self.sim.model, self.sim.data, self.sim
        st = LowState(mode_pr=self._mode_pr, mode_machine=self.mode_machine, tick=int(d.time * 1000) & 0xFFFFFFFF)
        s = sim.slots
        st.mode[s] = 1
        st.q[s], st.dq[s], st.ddq[s], st.tau_est[s] = d.qpos[sim.qpos], d.qvel[sim.dof], d.qacc[sim.dof], self.tau
        st.temperature[s] = 35
        st.vol[s] = 58.0
        quat = d.xquat[sim.pelvis].copy()
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, sim.pelvis, vel, 1)
        rot = d.xmat[sim.pelvis].reshape(3, 3)
        st.quaternion[:] = quat
        st.gyroscope[:] = vel[:3]
        st.accelerometer[:] = rot.T @ np.array([0.0, 0.0, 9.81])
        st.rpy[:] = quat_to_euler(quat)
        st.imu_temperature = 40
        return st


def _next_slot(slot: float, period: float, now: float) -> float:
    """The first slot of the grid `slot + k * period` after `now`: a late one is skipped, never burst."""
    return slot + max(1, math.floor((now - slot) / period) + 1) * period


def _stand_in_gains(joint: str) -> tuple[float, float]:
    if "wrist" in joint:
        return 40.0, 1.5
    if "ankle" in joint or "shoulder" in joint or "elbow" in joint:
        return 80.0, 3.0
    return 300.0, 3.0




__all__ = ["Bridge", "Counts", "NUM_SLOTS"]
