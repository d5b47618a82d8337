"""What every IK backend provides: forward kinematics of one tool frame and a numeric solver with
tolerances, iteration limits and random restarts, over the arm's own joints only.

Two uses share it:
- teleop / driver IK (`solve(target, q_current)` with no restarts): warm-started from the current
  joints, it returns the closest solution, or the best effort when the target is unreachable, so a
  teleoperated arm never jumps to another branch;
- offline solving (`restarts > 0`): when a start does not converge (a local minimum, a joint limit),
  try again from random joint configurations and keep the best.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from rio.control.se3 import as_pose, pose_error

DEFAULT_POS_TOL = 1e-3            # m
DEFAULT_ROT_TOL = np.deg2rad(1.0)  # rad
_CONTINUOUS = np.pi                # sample joints with huge limits (e.g. +-2 pi) within +-pi


def require(module: str, pip_name: str):
    """Import an optional backend, or say which extra installs it."""
    import importlib

    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as e:
        raise ModuleNotFoundError(f"rio.kinematics needs '{pip_name}' for this solver: "
                                  f"pip install 'rio-core[ik]' ({e})") from e


@dataclass
class IKResult:
    q: np.ndarray
    pos_err: float
    rot_err: float
    iterations: int
    success: bool
    restarts: int = 0
    seconds: float = 0.0


class IKSolver:
    """Subclasses set `joint_names`, `lower`, `upper` and implement `fk` and `_step`."""

    joint_names: list[str]
    lower: np.ndarray
    upper: np.ndarray
    #: Relative weight of orientation vs position errors (1 = full pose; small = position first,
    #: for arms with fewer than 6 joints, or for translation-only teleop).
    orientation_cost: float = 1.0

    @property
    def dof(self) -> int:
        return len(self.joint_names)

    def fk(self, q) -> np.ndarray:
        """Tool pose `[x, y, z, qw, qx, qy, qz]` in the model's base frame."""
        raise NotImplementedError

    def _step(self, q: np.ndarray, target: np.ndarray) -> np.ndarray:
        """One solver iteration from q towards target; returns the new q (within limits)."""
        raise NotImplementedError

    def clip(self, q) -> np.ndarray:
        return np.clip(np.asarray(q, dtype=np.float64), self.lower, self.upper)

    def random_q(self, rng: np.random.Generator) -> np.ndarray:
        lo = np.maximum(self.lower, -_CONTINUOUS)
        hi = np.minimum(self.upper, _CONTINUOUS)
        return rng.uniform(lo, hi)

    def _run(self, target: np.ndarray, q: np.ndarray, pos_tol: float, rot_tol: float,
             max_iters: int) -> tuple[np.ndarray, float, float, int]:
        best = (q, *pose_error(self.fk(q), target))
        best_cost = best[1] + 0.1 * best[2]
        polish = 2
        for it in range(1, max_iters + 1):
            q = self._step(q, target)
            pe, re = pose_error(self.fk(q), target)
            cost = pe + 0.1 * re
            if cost < best_cost:
                best, best_cost = (q, pe, re), cost
            if pe <= pos_tol and re <= rot_tol:
                polish -= 1  # within tolerance: a couple more (quadratically converging) steps are cheap
                if polish < 0 or (pe <= 0.01 * pos_tol and re <= 0.01 * rot_tol):
                    return best[0], best[1], best[2], it
        return best[0], best[1], best[2], max_iters

    def solve(self, target, q_init=None, *, pos_tol: float = DEFAULT_POS_TOL, rot_tol: float = DEFAULT_ROT_TOL,
              max_iters: int = 60, restarts: int = 0, rng: np.random.Generator | int | None = None) -> IKResult:
        """Joints reaching `target` (7-vector pose, base frame) to within the tolerances.

        `rot_tol=np.inf` solves for position only (orientation weight 0). On failure the result holds the best joints
        found, `success=False`, and the remaining errors."""
        if not np.isfinite(rot_tol):  # position only: orientation must not pull the solution away
            saved, self.orientation_cost = self.orientation_cost, 0.0
            try:
                return self.solve(target, q_init, pos_tol=pos_tol, rot_tol=np.pi, max_iters=max_iters,
                                  restarts=restarts, rng=rng)
            finally:
                self.orientation_cost = saved
        t0 = time.perf_counter()
        target = as_pose(target)
        q0 = self.clip(np.zeros(self.dof) if q_init is None else q_init)
        gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        tries, total_iters = 0, 0
        best: tuple[np.ndarray, float, float] | None = None
        while True:
            q, pe, re, iters = self._run(target, q0, pos_tol, rot_tol, max_iters)
            total_iters += iters
            ok = pe <= pos_tol and re <= rot_tol
            if best is None or (pe + 0.1 * re) < (best[1] + 0.1 * best[2]) or ok:
                best = (q, pe, re)
            if ok or tries >= restarts:
                break
            tries += 1
            q0 = self.random_q(gen)
        q, pe, re = best
        return IKResult(q=q, pos_err=pe, rot_err=re, iterations=total_iters,
                        success=bool(pe <= pos_tol and re <= rot_tol), restarts=tries,
                        seconds=time.perf_counter() - t0)
