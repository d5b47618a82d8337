"""Hands and humanoids: joint-space devices (`JointNode`), the humanoid adding its base IMU.

A humanoid driver returns `base_quat` (wxyz) and `base_ang_vel` (rad/s) from `read_joints()` with the
joints; gains and low-level modes live in the driver's config.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio.interfaces.joints import JointConfig, JointNode
from rio.runtime.node import remote


class HandNode(JointNode):
    """A multi-fingered hand, commanded in joint space (rad)."""

    @remote
    def robot_description(self) -> dict[str, Any] | None:
        """The hand's model for retargeting tracked human hands onto it (`rio.kinematics.HandRetargeter`), or
        None: `{"format": "mjcf", "xml": <model text>, "joints": [<names, in this node's joint order>],
        "keypoints": {<HAND_JOINTS name>: <site>}, "palm": <site>, "side": "right" | "left"}`."""
        return None


class HumanoidNode(JointNode):
    """A humanoid's whole body in joint space, plus its base IMU."""

    class Config(JointConfig):
        rate_hz: float = Field(500.0, gt=0, description="loop rate (Hz)")
        max_step_rad: float = Field(0.02, gt=0, description="largest joint goal change per cycle (rad)")

    @remote
    def robot_description(self) -> dict[str, Any] | None:
        """The body's model for placing its wrists by IK (`rio.kinematics.MultiFrameIK`), or None:
        `{"format": "mjcf", "xml": <model text>, "joints": [<names, in this node's joint order>],
        "frames": {"left": <site>, "right": <site>}, "frame_type": "site", "home": [<rad>] (optional)}`."""
        return None

    def setup(self) -> None:
        super().setup()
        self.example_data = {**self.example_data, "base_quat": np.array([1.0, 0.0, 0.0, 0.0]),
                             "base_ang_vel": np.zeros(3)}


HumanoidConfig = HumanoidNode.Config
