"""IK on MuJoCo models with mink (differential IK as a small QP, joint limits as constraints).

Solves for the named joints of a model (default: every hinge and slide joint); any other degree of
freedom (fingers, free-floating objects) is held fixed by a `DofFreezingTask`. The tool is a site
(preferred), body or geom of the model.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from rio.kinematics.base import IKSolver, require


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


def _one_dof(model: Any, joint: int) -> bool:
    mujoco = require("mujoco", "mujoco")
    return int(model.jnt_type[joint]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


def solvable_joints(model: Any) -> list[str]:
    """Every hinge and slide joint: what a solver moves when not told which (free joints are objects)."""
    return [model.joint(i).name for i in range(model.njnt) if _one_dof(model, i)]


def joint_table(model: Any, names: list[str]) -> tuple[np.ndarray, list[int], np.ndarray, np.ndarray]:
    """(qpos addresses, dof indices, lower, upper) of the named one-dof joints; unbounded where the model
    sets no range. The solvers index the model's full configuration through these."""
    mujoco = require("mujoco", "mujoco")
    ids = []
    for n in names:
        j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n)
        if j < 0:
            raise ValueError(f"joint '{n}' is not in the model")
        if not _one_dof(model, j):
            raise ValueError(f"joint '{n}' is not a hinge or slide joint")
        ids.append(j)
    qadr = np.array([model.jnt_qposadr[j] for j in ids], dtype=int)
    dofs = [int(model.jnt_dofadr[j]) for j in ids]
    limited = np.array([bool(model.jnt_limited[j]) for j in ids], dtype=bool)
    rng = np.array([model.jnt_range[j] for j in ids], dtype=np.float64).reshape(-1, 2)
    return qadr, dofs, np.where(limited, rng[:, 0], -np.inf), np.where(limited, rng[:, 1], np.inf)


def freeze_others(model: Any, dofs: list[int]) -> list[Any]:
    """The constraint holding every degree of freedom outside `dofs` still (none when nothing is left)."""
    mink = require("mink", "mink")
    frozen = sorted(set(range(model.nv)) - set(dofs))
    return [mink.DofFreezingTask(model, dof_indices=frozen)] if frozen else []


def frame_body(model: Any, name: str, frame_type: str = "site") -> int:
    """The body carrying a site, body or geom, which is what decides the joints that move it."""
    mujoco = require("mujoco", "mujoco")
    kinds = {"site": mujoco.mjtObj.mjOBJ_SITE, "body": mujoco.mjtObj.mjOBJ_BODY, "geom": mujoco.mjtObj.mjOBJ_GEOM}
    if frame_type not in kinds:
        raise ValueError(f"frame type {frame_type!r}: write 'site', 'body' or 'geom'")
    i = mujoco.mj_name2id(model, kinds[frame_type], name)
    if i < 0:
        raise ValueError(f"{frame_type} '{name}' is not in the model")
    if frame_type == "site":
        return int(model.site_bodyid[i])
    return int(model.geom_bodyid[i]) if frame_type == "geom" else int(i)


def joints_moving(model: Any, body: int) -> set[int]:
    """The ids of the joints between the world and `body`: the only ones that can move it."""
    out: set[int] = set()
    while body > 0:
        start, n = int(model.body_jntadr[body]), int(model.body_jntnum[body])
        out.update(range(start, start + n) if start >= 0 else ())
        body = int(model.body_parentid[body])
    return out


class MinkSolver(IKSolver):
    def __init__(self, model: Any, frame: str, *, frame_type: str = "site", joints: list[str] | None = None,
                 orientation_cost: float = 1.0, damping: float = 1e-4, solver: str = "daqp"):
        mink = require("mink", "mink")
        mujoco = require("mujoco", "mujoco")
        self._mink, self._mj = mink, mujoco
        self.model = load_mujoco_model(model)
        m = self.model
        self.joint_names = list(solvable_joints(m) if joints is None else joints)
        self._qadr, dofs, self.lower, self.upper = joint_table(m, self.joint_names)
        self.frame, self.frame_type = frame, frame_type
        self.orientation_cost, self.damping, self.solver = float(orientation_cost), float(damping), solver
        self.configuration = mink.Configuration(m)
        self._q_full = m.qpos0.copy()
        self.task = mink.FrameTask(frame, frame_type, position_cost=1.0, orientation_cost=self.orientation_cost,
                                   lm_damping=1e-6)
        self._constraints = freeze_others(m, dofs)
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
