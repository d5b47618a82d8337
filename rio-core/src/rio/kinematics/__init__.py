"""Shared inverse kinematics (optional extra: `pip install rio-core[ik]`).

- `MinkSolver`: MuJoCo models (MJCF) through mink; what the simulated arms and teleop use.
- `PinocchioSolver`: URDF models through pinocchio; for vendor URDFs and humanoid retargeting.
- `solver_from_description`: the right solver for an arm's `robot_description()`.
- `HandRetargeter`: a tracked human hand's keypoints to a dexterous hand's joints (mink); defines RIO's
  palm frame (`palm_pose`).
- `MultiFrameIK`: several frames of one model solved together (a humanoid's wrists; mink).

Used for end-effector teleop of arms without Cartesian control and for retargeting. Backends are
imported on first use, so `import rio.kinematics` works without the extra and fails only, with a
clear message, when a solver is built.
"""

from __future__ import annotations

from typing import Any

from rio.kinematics.base import DEFAULT_POS_TOL, DEFAULT_ROT_TOL, IKResult, IKSolver
from rio.kinematics.description import mjcf_description, read_model, solver_from_description, tool_pose_from_offset

__all__ = ["IKSolver", "IKResult", "MinkSolver", "PinocchioSolver", "solver_from_description", "mjcf_description",
           "tool_pose_from_offset", "read_model", "HandRetargeter", "palm_pose", "MultiFrameIK",
           "DEFAULT_POS_TOL", "DEFAULT_ROT_TOL"]

_BACKENDS = {"MinkSolver": "mink_solver", "PinocchioSolver": "pin_solver", "HandRetargeter": "hand_retarget",
             "palm_pose": "hand_retarget", "MultiFrameIK": "multi_frame"}


def __getattr__(name: str) -> Any:
    if name in _BACKENDS:
        import importlib

        return getattr(importlib.import_module(f"{__name__}.{_BACKENDS[name]}"), name)
    raise AttributeError(f"module 'rio.kinematics' has no attribute '{name}'")
