"""`onnx.locomotion`: an RL locomotion controller (an ONNX export of a legged_gym / unitree_rl_gym actor) on
a humanoid station: a velocity command in, the whole body's joint targets out, one action per policy step
(50 Hz by default); the driver's joint PD tracks them (at 500 Hz on a G1; at the physics rate in rio-sim).

Observation (float32 `[1, N]`, the terms of `obs` in order; defaults: unitree_rl_gym's G1, 47 values):

| term          | size | value                                                                   |
|---------------|------|-------------------------------------------------------------------------|
| `ang_vel`     | 3    | base (pelvis IMU) angular velocity, body frame, rad/s x `ang_vel_scale`  |
| `gravity`     | 3    | projected gravity: R(base_quat)^T [0, 0, -1] ([0, 0, -1] upright)       |
| `command`     | 3    | [vx m/s, vy m/s, wz rad/s] x `command_scale`                            |
| `joint_pos`   | n    | (q - default_pose) x `dof_pos_scale`, for the policy's `joints`         |
| `joint_vel`   | n    | dq x `dof_vel_scale`, same joints                                       |
| `last_action` | n    | the previous raw model output (after `clip_actions`); zeros after reset |
| `phase`       | 2    | sin, cos of 2 pi (t / `phase_period_s` mod 1), t since reset + one step |

each clipped to +-`clip_obs`. Action: target(joints) = default_pose + `action_scale` x clip(output,
+-`clip_actions`); every other body joint holds its default pose (0 where `default_pose` names none),
hand joints (a station's `hand`, `hand2`) hold where they were at the first observation.

The defaults are unitree_rl_gym's G1 (12 leg joints) as its sources state them: default joint angles,
`action_scale` 0.25 and 50 Hz (`legged_gym/envs/g1/g1_config.py`: sim dt 0.005 x decimation 4), the
observation scales and clips of legged_gym's `LeggedRobotCfg.normalization` (ang_vel 0.25, dof_pos 1.0,
dof_vel 0.05, commands [lin_vel 2.0, lin_vel 2.0, ang_vel 0.25], clip 100), the term order of
`legged_gym/envs/g1/g1_env.py` `compute_observations` and its gait phase (period 0.8 s), as
`deploy/deploy_mujoco/deploy_mujoco.py` assembles them (47 = 3 + 3 + 3 + 12 + 12 + 12 + 2). Base linear
velocity (legged_gym's quadrupeds' first term) is not measured by an IMU and is not offered.

The command is `command` (constant), or with `command_from = "teleop"` the station's teleop device's
twist (linear x, y and angular z, times `twist_gain`, zeroed within `deadband`, clipped to +-`command_max`:
`rio_policies.velocity_command`), read at each policy step.

Recurrent actors (unitree_rl_gym's G1 is an LSTM): a model with more than one input treats inputs 2..k as
its state, fed back from outputs 2..k of the previous step (zeros after reset).
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field, model_validator

from rio.policy import Policy, PolicyConfig, PolicyMetadata, PolicyNode
from rio.schema import Observation

_LEG = ("hip_pitch", "hip_roll", "hip_yaw", "knee", "ankle_pitch", "ankle_roll")
_ARM = ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow", "wrist_roll", "wrist_pitch", "wrist_yaw")
#: The G1's 29 joints in Unitree's motor order (LowCmd/LowState slots 0-28): `sim.g1` and `unitree.g1`.
G1_JOINTS: tuple[str, ...] = (
    *(f"left_{j}_joint" for j in _LEG), *(f"right_{j}_joint" for j in _LEG),
    "waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint",
    *(f"left_{j}_joint" for j in _ARM), *(f"right_{j}_joint" for j in _ARM),
)
#: The 23-DoF G1 (`unitree.g1_23dof`): no waist roll/pitch, no wrist pitch/yaw.
G1_23_JOINTS: tuple[str, ...] = tuple(j for j in G1_JOINTS if j not in {
    "waist_roll_joint", "waist_pitch_joint", "left_wrist_pitch_joint", "left_wrist_yaw_joint",
    "right_wrist_pitch_joint", "right_wrist_yaw_joint"})
G1_LEGS: tuple[str, ...] = G1_JOINTS[:12]
#: unitree_rl_gym's G1 default joint angles (rad; 0 for the joints it does not list).
G1_DEFAULT_POSE: dict[str, float] = {
    f"{side}_{j}_joint": v for side in ("left", "right")
    for j, v in (("hip_pitch", -0.1), ("hip_roll", 0.0), ("hip_yaw", 0.0), ("knee", 0.3), ("ankle_pitch", -0.2),
                 ("ankle_roll", 0.0))}

Term = Literal["ang_vel", "gravity", "command", "joint_pos", "joint_vel", "last_action", "phase"]
UNITREE_RL_GYM_G1: list[str] = ["ang_vel", "gravity", "command", "joint_pos", "joint_vel", "last_action", "phase"]


def projected_gravity(quat_wxyz: Any) -> np.ndarray:
    """Gravity's direction in the base frame: R(q)^T [0, 0, -1] for a unit quaternion wxyz."""
    w, x, y, z = np.asarray(quat_wxyz, dtype=np.float64) / np.linalg.norm(quat_wxyz)
    return np.array([2.0 * (w * y - x * z), -2.0 * (w * x + y * z), -(w * w - x * x - y * y + z * z)])


class LocomotionPolicy(Policy):
    name = "onnx.locomotion"

    class Config(PolicyConfig):
        path: str = Field(description="the .onnx file (input: the observation [1, N]; first output: [1, n] actions)")
        command: list[float] = Field([0.0, 0.0, 0.0], min_length=3, max_length=3,
                                     description="constant velocity command [vx m/s, vy m/s, wz rad/s], base frame")
        command_from: str | None = Field(None, description='a station teleop role ("teleop", "teleop2"): the command '
                                                           "is that device's twist instead of `command`")
        twist_gain: list[float] = Field([1.0, 1.0, 1.0], min_length=3, max_length=3,
                                        description="command per unit of the device's linear x, y (m/s) and angular "
                                                    "z (rad/s)")
        deadband: list[float] = Field([0.05, 0.05, 0.05], min_length=3, max_length=3,
                                      description="command components smaller than this are 0 (m/s, m/s, rad/s)")
        command_max: list[float] = Field([1.0, 0.5, 1.0], min_length=3, max_length=3,
                                         description="the command is clipped to +- this (m/s, m/s, rad/s)")
        command_timeout_s: float = Field(0.5, gt=0, description="a device silent this long commands standing still")
        joints: list[str] = Field(list(G1_LEGS), min_length=1,
                                  description="the joints the model drives, in its output (and observation) order; "
                                              "default: the G1's 12 leg joints")
        body_joints: list[str] | None = Field(
            None, description="the station body's joints in its action order; default: the G1's 29 in Unitree's "
                              "motor order (23 when the body has 23 joints)")
        default_pose: dict[str, float] = Field(default_factory=lambda: dict(G1_DEFAULT_POSE),
                                               description="joint -> angle (rad) at action 0; unnamed joints: 0")
        obs: list[Term] = Field(default_factory=lambda: list(UNITREE_RL_GYM_G1),
                                description="observation terms in order (see the module docstring)")
        ang_vel_scale: float = 0.25
        command_scale: list[float] = Field([2.0, 2.0, 0.25], min_length=3, max_length=3)
        dof_pos_scale: float = 1.0
        dof_vel_scale: float = 0.05
        action_scale: float = 0.25
        clip_obs: float = Field(100.0, gt=0)
        clip_actions: float = Field(100.0, gt=0)
        phase_period_s: float = Field(0.8, gt=0, description="gait clock period of the `phase` term")
        rate_hz: float = Field(50.0, gt=0, description="policy rate the model was trained at")
        ramp_s: float = Field(2.0, ge=0, description="after reset, move the body from where it is to default_pose "
                                                     "over this long before the model runs (0: run at once)")
        input: str | None = Field(None, description="observation input name (default: the model's first)")
        threads: int = Field(1, ge=1, description="onnxruntime intra-op threads")

        @model_validator(mode="after")
        def _known_joints(self) -> LocomotionPolicy.Config:
            body = self.body_joints
            if body is not None:
                missing = [j for j in self.joints if j not in body]
                if missing:
                    raise ValueError(f"joints {missing} are not among body_joints")
            return self

    def setup(self) -> None:
        self.session: Any = None
        self.t0: float | None = None
        self.t_obs = 0.0
        self.last = np.zeros(len(self.config.joints))
        self.held: np.ndarray | None = None
        self.state: dict[str, np.ndarray] = {}
        self.device: Any = None  # rio_policies.velocity_command.DeviceCommand with command_from

    # -- loading ------------------------------------------------------------------------------------
    def load(self, layout: Any) -> None:
        import onnxruntime as ort

        super().load(layout)
        c = self.config
        nbody = int(layout.fields.get("joint_pos", [0])[0]) if layout.fields.get("joint_pos") else 0
        if not nbody or "base_quat" not in layout.fields:
            raise ValueError(f"'{self.name}' runs on a humanoid station (joint_pos, base_quat); this one's observation "
                             f"is {layout.obs_type}")
        body = list(c.body_joints) if c.body_joints is not None else list(G1_23_JOINTS if nbody == 23 else G1_JOINTS)
        if len(body) != nbody:
            raise ValueError(f"the station's body has {nbody} joints, body_joints names {len(body)}")
        missing = [j for j in c.joints if j not in body]
        if missing:
            raise ValueError(f"joints {missing} are not on this body ({nbody} joints); set body_joints")
        self.idx = np.array([body.index(j) for j in c.joints])
        self.default_body = np.array([c.default_pose.get(j, 0.0) for j in body])
        self.default = self.default_body[self.idx]
        self.nbody = nbody
        if c.command_from is not None:
            from .velocity_command import DeviceCommand

            self.device = DeviceCommand(layout, c.command_from, c.twist_gain, c.deadband, c.command_max,
                                        c.command_timeout_s)
        opts = ort.SessionOptions()
        opts.intra_op_num_threads = c.threads
        self.session = ort.InferenceSession(c.path, opts, providers=["CPUExecutionProvider"])
        inputs, outputs = self.session.get_inputs(), self.session.get_outputs()
        self.in_name = c.input or inputs[0].name
        self.state_in = [i for i in inputs if i.name != self.in_name]
        if len(outputs) < 1 + len(self.state_in):
            raise ValueError(f"{c.path}: {len(self.state_in)} state inputs but {len(outputs)} outputs")
        self.out_names = [o.name for o in outputs[:1 + len(self.state_in)]]
        want = self.obs_size()
        shape = next(i.shape for i in inputs if i.name == self.in_name)
        if shape and isinstance(shape[-1], int) and shape[-1] != want:
            raise ValueError(f"{c.path} takes {shape[-1]} observation values; the layout {self.describe()} "
                             f"makes {want}")
        oshape = outputs[0].shape
        if oshape and isinstance(oshape[-1], int) and oshape[-1] != len(c.joints):
            raise ValueError(f"{c.path} outputs {oshape[-1]} actions; joints names {len(c.joints)}")
        self.reset()

    def close(self) -> None:
        if self.device is not None:
            self.device.close()
            self.device = None

    def command(self) -> np.ndarray:
        """The velocity command [vx, vy, wz] of this step (unscaled)."""
        return self.device() if self.device is not None else np.asarray(self.config.command, dtype=np.float64)

    def obs_size(self) -> int:
        n = len(self.config.joints)
        sizes = {"ang_vel": 3, "gravity": 3, "command": 3, "joint_pos": n, "joint_vel": n, "last_action": n,
                 "phase": 2}
        return sum(sizes[t] for t in self.config.obs)

    def describe(self) -> list[tuple[str, int, int]]:
        """The observation layout: (term, start, end) per term."""
        n = len(self.config.joints)
        sizes = {"ang_vel": 3, "gravity": 3, "command": 3, "joint_pos": n, "joint_vel": n, "last_action": n,
                 "phase": 2}
        out, i = [], 0
        for t in self.config.obs:
            out.append((t, i, i + sizes[t]))
            i += sizes[t]
        return out

    def metadata(self) -> PolicyMetadata:
        # offset 0.5: the action is for about when it lands (a millisecond after its observation, then tracked
        # over one period), not a whole period later; with offset 1 `rio deploy` would find it still ahead at
        # the next tick and ask only every other tick (25 Hz)
        return PolicyMetadata(self.name, self.layout.action_dim, 1, 1.0 / self.config.rate_hz, offset=0.5,
                              extra={"obs": [list(t) for t in self.describe()], "joints": list(self.config.joints)})

    def reset(self) -> None:
        self.t0, self.held = None, None
        self.last = np.zeros(len(self.config.joints))
        self.state = {}
        if self.session is not None:
            for i in self.state_in:
                shape = [d if isinstance(d, int) else 1 for d in i.shape]
                self.state[i.name] = np.zeros(shape, np.float32)

    # -- one step -----------------------------------------------------------------------------------
    def __call__(self, obs: Observation, instruction: str | None, t_obs: float, seq: int = 0,
                 t_recv: float | None = None):
        self.t_obs = float(t_obs)
        return super().__call__(obs, instruction, t_obs, seq, t_recv)

    def observation(self, obs: Any) -> np.ndarray:
        """The model's input vector (1-D float64) for `obs`."""
        c = self.config
        if self.t0 is None:
            self.t0 = self.t_obs
            proprio = np.asarray(obs.proprio, dtype=np.float64)
            self.held = proprio[self.nbody:].copy()  # hands: where they are
            self.start = proprio[:self.nbody].copy()
        q = np.asarray(obs.joint_pos, dtype=np.float64)[self.idx]
        dq = np.asarray(obs.joint_vel, dtype=np.float64)[self.idx]
        parts = []
        for term in c.obs:
            if term == "ang_vel":
                parts.append(np.asarray(obs.base_ang_vel, dtype=np.float64) * c.ang_vel_scale)
            elif term == "gravity":
                parts.append(projected_gravity(obs.base_quat))
            elif term == "command":
                parts.append(self.command() * np.asarray(c.command_scale))
            elif term == "joint_pos":
                parts.append((q - self.default) * c.dof_pos_scale)
            elif term == "joint_vel":
                parts.append(dq * c.dof_vel_scale)
            elif term == "last_action":
                parts.append(self.last)
            else:  # phase: time since reset plus one step, as the training env counts it after stepping
                t = max(self.t_obs - self.t0 - c.ramp_s, 0.0) + 1.0 / c.rate_hz
                ph = 2.0 * np.pi * ((t / c.phase_period_s) % 1.0)
                parts.append(np.array([np.sin(ph), np.cos(ph)]))
        return np.clip(np.concatenate(parts), -c.clip_obs, c.clip_obs)

    def prepare(self, obs: Observation, instruction: str | None) -> np.ndarray:
        return self.observation(obs).astype(np.float32)[None, :]

    def ramping(self) -> float | None:
        """During the start ramp, how far along it (0..1) the next target is; None once the model runs."""
        c = self.config
        if self.t0 is None or c.ramp_s <= 0:
            return None
        s = (self.t_obs - self.t0 + 1.0 / c.rate_hz) / c.ramp_s
        return None if s > 1.0 + 1e-6 else min(s, 1.0)

    def infer(self, x: np.ndarray) -> np.ndarray:
        c = self.config
        s = self.ramping()
        if s is not None:  # Unitree's deploy does the same: to the default pose first, the model after
            body = self.start + s * (self.default_body - self.start)
            return np.concatenate([body, self.held])[None, :]
        outs = self.session.run(self.out_names, {self.in_name: x, **self.state})
        for i, o in zip(self.state_in, outs[1:], strict=True):
            self.state[i.name] = np.asarray(o, np.float32).reshape(self.state[i.name].shape)
        raw = np.asarray(outs[0], dtype=np.float64).reshape(-1)
        if raw.size != len(c.joints):
            raise ValueError(f"{c.path} output {raw.size} actions; joints names {len(c.joints)}")
        self.last = np.clip(raw, -c.clip_actions, c.clip_actions)
        body = self.default_body.copy()
        body[self.idx] = self.default + c.action_scale * self.last
        return np.concatenate([body, self.held])[None, :]


LocomotionConfig = LocomotionPolicy.Config


class LocomotionNode(PolicyNode):
    policy_class = LocomotionPolicy


__all__ = ["G1_DEFAULT_POSE", "G1_JOINTS", "G1_LEGS", "LocomotionNode", "LocomotionPolicy", "projected_gravity"]
