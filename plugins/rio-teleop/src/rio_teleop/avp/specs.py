"""What `teleop.avp` registers (merged into rio_teleop.plugin's hooks). Specs only: nothing here imports
avp_stream."""

from __future__ import annotations

from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec


def drivers() -> list[Spec]:
    return [Spec("teleop.avp", "teleop", "rio_teleop.avp.node:VisionProTeleop",
                 "Apple Vision Pro native hand tracking (the Tracking Streamer app, avp-stream over gRPC): wrist "
                 "poses and hand keypoints for arms, humanoids and dexterous hands, pinch gripper")]


def requirements() -> list[Requirement]:
    return [Requirement("avp_stream", "pip install 'rio-teleop[avp]'",
                        "teleop.avp: Apple Vision Pro hand tracking (the Tracking Streamer app)")]
