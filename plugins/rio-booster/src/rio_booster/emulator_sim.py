"""The emulated T1's physics backend (`EmulatedT1(backend="sim...")`): rio-sim's T1 in MuJoCo, on its stand at
rio-sim's T1 table (scene `t1`, with its cube), or free-floating (`sim:floating`). Imported only when asked
for: rio-sim and MuJoCo stay optional.

Why the emulator owns this physics instead of attaching to a station's `sim.world` (as the arm emulators
do): a world's humanoid joints are position servos (one kp, kd per joint, a target the world interpolates)
and, on the stand, carry their own weight by MuJoCo's gravity compensation. The T1's motors obey each
command's kp, kd, q, dq and tau at the physics rate, a damped arm falls, and nothing compensates gravity
but the command's tau: none of that can be said through the world bus. So the emulator steps its own
copy of the scene with the asset's torque motors back (force = kp (q* - q) + kd (dq* - dq) + tau,
limited to each joint's effort, inside MuJoCo's step so the damping is integrated implicitly) and
without gravity compensation, and it is itself the station's world: it creates the world bus under its
`world` name and writes its state there, so the station's `sim.camera` nodes render this robot and cube
(a station with the sim backend has no `sim.world` of that name).

The IMU is the trunk's: roll, pitch, yaw of its orientation, its angular velocity in its own frame, and
gravity in its frame as the accelerometer reads it at rest. On the stand `tilt()` turns the mounted
trunk (a fall, as the IMU sees one, on a robot that cannot fall).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rio.control.rotations import euler_to_quat, quat_to_euler

from .t1 import JOINTS, NUM_JOINTS

PREFIX = "t1"  # the T1's name prefix in rio-sim's scene


def parse_backend(backend: str) -> tuple[bool, str]:
    """`'sim'`, `'sim:floating'`, `'sim@WORLD'` or `'sim:floating@WORLD'` -> (mounted, world name)."""
    head, _, world = backend.partition("@")
    kind, _, variant = head.partition(":")
    if kind != "sim" or variant not in ("", "floating", "mounted") or (backend.count("@") and not world):
        raise ValueError(f"unknown emulated T1 backend '{backend}': 'ideal', 'sim', 'sim:floating', "
                         "'sim@WORLD' or 'sim:floating@WORLD'")
    return variant != "floating", world or "sim"


def _rio_sim() -> Any:
    try:
        import mujoco  # noqa: F401
        import rio_sim
    except ImportError as e:
        raise ImportError(f"the emulated T1's 'sim' backend needs rio-sim and MuJoCo ({e}): pip install rio-sim "
                          "(or pip install 'rio-booster[sim]')") from e
    return rio_sim


def build_model(mounted: bool) -> Any:
    """rio-sim's T1 scene with the T1's servos made the robot's motors again: force = ctrl - kp q - kd dq
    (an affine bias whose kp, kd `SimT1Physics` sets from each command), limited to the joint's effort;
    no gravity compensation."""
    _rio_sim()
    import mujoco
    from rio_sim.scenes import build_spec, get_scene, scene_key

    spec = build_spec(get_scene(scene_key("t1", mounted)))
    for act in spec.actuators:
        if not act.name.startswith(f"{PREFIX}/"):
            continue
        act.gaintype, act.biastype = mujoco.mjtGain.mjGAIN_FIXED, mujoco.mjtBias.mjBIAS_AFFINE
        act.gainprm[:3] = [1.0, 0.0, 0.0]
        act.biasprm[:3] = [0.0, 0.0, 0.0]
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE  # the joint's actuatorfrcrange limits the force
    for body in spec.bodies:
        body.gravcomp = 0.0
    for joint in spec.joints:
        joint.actgravcomp = False
    return spec.compile()


class SimT1Physics:
    """The T1's joints, trunk and IMU in MuJoCo, stepped by `step()` under a motor law; the scene's state
    served on the world bus `world` between `open_bus()` and `close_bus()`."""

    def __init__(self, backend: str, start_q: np.ndarray):
        import mujoco
        from rio_sim.indices import joint_indices
        from rio_sim.scenes import scene_key

        self._mj = mujoco
        self.mounted, self.world = parse_backend(backend)
        self.scene = scene_key("t1", self.mounted)
        self.model = m = build_model(self.mounted)
        self.data = mujoco.MjData(m)
        self.idx = joint_indices(m, PREFIX, [j.name for j in JOINTS])
        self.trunk = int(m.body(f"{PREFIX}/Trunk").id)
        self._quat0 = m.body_quat[self.trunk].copy()
        free = f"{PREFIX}/floating_base_joint"
        self._free = None if self.mounted else (int(m.joint(free).qposadr[0]), int(m.joint(free).dofadr[0]))
        self.dt = float(m.opt.timestep)
        self._carry = 0.0
        self.bus: Any = None
        self.reset(start_q)

    def reset(self, q: np.ndarray) -> None:
        mj, m, d = self._mj, self.model, self.data
        mj.mj_resetData(m, d)
        d.qpos[self.idx.qpos] = q
        mj.mj_forward(m, d)

    # -- the motor law ---------------------------------------------------------------------------------
    def step(self, seconds: float, kp: np.ndarray, kd: np.ndarray, q: np.ndarray, dq: np.ndarray, tau: np.ndarray,
             hold_gravity: bool = False) -> None:
        """Advance `seconds` (whole physics steps; the rest is carried to the next call) with every motor at
        tau = kp (q - q_now) + kd (dq - dq_now) + tau (`hold_gravity`: plus the joints' gravity torque, as a
        controller holding a pose adds it)."""
        mj, m, d, act = self._mj, self.model, self.data, self.idx.act
        self._carry += seconds
        n = int(self._carry / self.dt)
        self._carry -= n * self.dt
        m.actuator_biasprm[act, 1] = -kp
        m.actuator_biasprm[act, 2] = -kd
        base = kp * q + kd * dq + tau
        for _ in range(n):
            d.ctrl[act] = base + (d.qfrc_bias[self.idx.dof] if hold_gravity else 0.0)
            mj.mj_step(m, d)

    # -- what the low state reports ----------------------------------------------------------------------
    def joints(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, dq and each motor's torque of the last step."""
        d = self.data
        return d.qpos[self.idx.qpos].copy(), d.qvel[self.idx.dof].copy(), d.actuator_force[self.idx.act].copy()

    def imu(self) -> tuple[np.ndarray, np.ndarray]:
        """The trunk's roll, pitch, yaw and its angular velocity in its own frame."""
        d = self.data
        rpy = quat_to_euler(d.xquat[self.trunk])
        if self._free is None:
            return rpy, np.zeros(3)
        return rpy, d.qvel[self._free[1] + 3:self._free[1] + 6].copy()  # a free joint's is in the body frame

    def tilt(self, rpy: np.ndarray) -> None:
        """Turn the trunk to `rpy` (on the stand: the mount; free: the base, at rest)."""
        q = euler_to_quat(*rpy)
        m, d = self.model, self.data
        if self._free is None:
            out = np.empty(4)
            self._mj.mju_mulQuat(out, q, self._quat0)
            m.body_quat[self.trunk] = out
        else:
            a, v = self._free
            d.qpos[a + 3:a + 7] = q
            d.qvel[v:v + 6] = 0.0
        self._mj.mj_forward(m, d)

    def trunk_pos(self) -> np.ndarray:
        return self.data.xpos[self.trunk].copy()

    # -- the world bus -------------------------------------------------------------------------------------
    def open_bus(self) -> None:
        """Serve this physics as world `world`: sim.camera nodes attach to it and render it."""
        from rio_sim.bus import WorldBus

        m = self.model
        self.bus = WorldBus.create(self.world, self.scene, m.nq, m.nv, m.nu)
        self.publish_bus()
        self.bus.mark_ready()

    def publish_bus(self) -> None:
        if self.bus is not None:
            d = self.data
            self.bus.write_state(d.time, d.qpos, d.qvel, d.ctrl)

    def close_bus(self) -> None:
        if self.bus is not None:
            self.bus.close()
            self.bus = None


def make(backend: str, start_q: np.ndarray) -> SimT1Physics:
    """The physics of `backend` (see `parse_backend`), its T1 at `start_q` (23 joints, JointIndex order)."""
    parse_backend(backend)
    _rio_sim()
    if np.shape(start_q) != (NUM_JOINTS,):
        raise ValueError(f"start_q: {NUM_JOINTS} joint positions, got shape {np.shape(start_q)}")
    return SimT1Physics(backend, np.asarray(start_q, np.float64))
