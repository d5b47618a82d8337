"""IK on MuJoCo models with mink (differential IK as a small QP, joint limits as constraints).

Solves for the named joints of a model (default: every hinge and slide joint); any other degree of
freedom (fingers, free-floating objects) is held fixed by a `DofFreezingTask`. The tool is a site
(preferred), body or geom of the model.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from .base import IKSolver, require


def load_mujoco_model(model: Any):
    """An MjModel from an MjModel, an .xml path or an MJCF string."""
    mujoco = require("mujoco", "mujoco")
    if isinstance(model, mujoco.MjModel):
        return model
    text = str(model)
    if text.lstrip().startswith("<"):
        return mujoco.MjModel.from_xml_string(text)
    if not os.path.isfile(text):
        raise FileNotFoundError(f"MJCF model not found: {text}")
    return mujoco.MjModel.from_xml_path(text)


class MinkSolver(IKSolver):
    def __init__(self, model: Any, frame: str, *, frame_type: str = "site", joints: list[str] | None = None,
                 orientation_cost: float = 1.0, damping: float = 1e-4, solver: str = "daqp"):
        mink = require("mink", "mink")
        mujoco = require("mujoco", "mujoco")
        self._mink, self._mj = mink, mujoco
        self.model = load_mujoco_model(model)
        m = self.model
        if joints is None:
            joints = [m.joint(i).name for i in range(m.njnt)
                      if int(m.jnt_type[i]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))]
        self.joint_names = list(joints)
        ids = [m.joint(n).id for n in self.joint_names]
        self._qadr = np.array([m.jnt_qposadr[j] for j in ids], dtype=int)
        dofs = [int(m.jnt_dofadr[j]) for j in ids]
        limited = np.array([bool(m.jnt_limited[j]) for j in ids])
        rng = np.array([m.jnt_range[j] for j in ids]).reshape(-1, 2)
        self.lower = np.where(limited, rng[:, 0], -np.inf)
        self.upper = np.where(limited, rng[:, 1], np.inf)
        self.frame, self.frame_type = frame, frame_type
        self.orientation_cost, self.damping, self.solver = float(orientation_cost), float(damping), solver
        self.configuration = mink.Configuration(m)
        self._q_full = m.qpos0.copy()
        self.task = mink.FrameTask(frame, frame_type, position_cost=1.0, orientation_cost=self.orientation_cost,
                                   lm_damping=1e-6)
        frozen = sorted(set(range(m.nv)) - set(dofs))
        self._constraints = [mink.DofFreezingTask(m, dof_indices=frozen)] if frozen else []
        self._limits = [mink.ConfigurationLimit(m, gain=0.95)]

    def set_fixed(self, qpos_full) -> None:
        """The values of the joints not solved for (full `qpos`)."""
        self._q_full = np.array(qpos_full, dtype=np.float64)

    def _full(self, q) -> np.ndarray:
        full = self._q_full.copy()
        full[self._qadr] = q
        return full

    def fk(self, q) -> np.ndarray:
        cfg = self.configuration
        cfg.update(self._full(q))
        t = cfg.get_transform_frame_to_world(self.frame, self.frame_type)
        w = t.wxyz_xyz
        return np.concatenate([w[4:], w[:4]])

    def _step(self, q: np.ndarray, target: np.ndarray) -> np.ndarray:
        mink = self._mink
        cfg = self.configuration
        cfg.update(self._full(q))
        self.task.set_orientation_cost(self.orientation_cost)
        self.task.set_target(mink.SE3(np.concatenate([target[3:], target[:3]])))
        v = mink.solve_ik(cfg, [self.task], 1.0, self.solver, damping=self.damping, limits=self._limits,
                          constraints=self._constraints or None)
        cfg.integrate_inplace(v, 1.0)
        return self.clip(cfg.q[self._qadr])
