"""IK on URDF models with pinocchio: damped least squares on the SE(3) log error (Gauss-Newton with
Levenberg-Marquardt damping), joint limits enforced by clipping each step.

For arms described by URDF (most vendors ship one) and for humanoid retargeting on URDF models.
Joints not solved for are locked at their reference values (a reduced model), so a hand's fingers
or a humanoid's legs stay put.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from rio.kinematics.base import IKSolver, require
from rio.machine.system_needs import SystemNeed

#: The OpenMP runtime pinocchio's wheel links (not in a minimal Debian): without it `import pinocchio`
#: raises ImportError.
LIBGOMP = SystemNeed("libgomp1", library="libgomp.so.1", purpose="pinocchio, which links it")


class PinocchioSolver(IKSolver):
    def __init__(self, urdf: Any, frame: str, *, joints: list[str] | None = None, orientation_cost: float = 1.0,
                 damping: float = 1e-6, q_reference: dict[str, float] | None = None):
        pin = require("pinocchio", "pin")
        self._pin = pin
        text = str(urdf)
        full = pin.buildModelFromXML(text) if text.lstrip().startswith("<") else self._from_path(text)
        names = [n for n in full.names[1:]]
        if joints is not None:
            unknown = sorted(set(joints) - set(names))
            if unknown:
                raise ValueError(f"joints {unknown} are not in the URDF; it has {names}")
            locked = [full.getJointId(n) for n in names if n not in joints]
            qref = pin.neutral(full)
            for n, v in (q_reference or {}).items():
                qref[full.joints[full.getJointId(n)].idx_q] = v
            model = pin.buildReducedModel(full, locked, qref) if locked else full
        else:
            model = full
        if not model.existFrame(frame):
            raise ValueError(f"frame '{frame}' is not in the URDF")
        if model.nq != model.nv:
            raise ValueError("PinocchioSolver supports revolute and prismatic joints only (nq == nv)")
        self.model, self.data = model, model.createData()
        self.frame_id = model.getFrameId(frame)
        self.joint_names = list(model.names[1:])
        self.lower = np.array(model.lowerPositionLimit, dtype=np.float64)
        self.upper = np.array(model.upperPositionLimit, dtype=np.float64)
        self.orientation_cost, self.damping = float(orientation_cost), float(damping)

    @staticmethod
    def _from_path(path: str):
        import pinocchio as pin

        if not os.path.isfile(path):
            raise FileNotFoundError(f"URDF not found: {path}")
        return pin.buildModelFromUrdf(path)

    def _placement(self, q):
        pin = self._pin
        pin.framesForwardKinematics(self.model, self.data, np.asarray(q, dtype=np.float64))
        return self.data.oMf[self.frame_id]

    def fk(self, q) -> np.ndarray:
        pin = self._pin
        m = self._placement(q)
        quat = pin.Quaternion(m.rotation)  # coeffs are x, y, z, w
        c = quat.coeffs()
        return np.array([*m.translation, c[3], c[0], c[1], c[2]])

    def _step(self, q: np.ndarray, target: np.ndarray) -> np.ndarray:
        pin = self._pin
        quat = pin.Quaternion(float(target[3]), float(target[4]), float(target[5]), float(target[6]))
        quat.normalize()
        goal = pin.SE3(quat.matrix(), np.asarray(target[:3]))
        current = self._placement(q)
        i_m_d = current.actInv(goal)                 # goal seen from the current tool frame
        err = pin.log6(i_m_d).vector                 # twist (local frame) that reaches it
        jac = pin.computeFrameJacobian(self.model, self.data, q, self.frame_id, pin.LOCAL)
        jac = pin.Jlog6(i_m_d.inverse()) @ jac
        w = np.array([1.0, 1.0, 1.0, *([np.sqrt(self.orientation_cost)] * 3)])
        jw, ew = jac * w[:, None], err * w
        dq = jw.T @ np.linalg.solve(jw @ jw.T + self.damping * np.eye(6), ew)
        return self.clip(pin.integrate(self.model, q, dq))
