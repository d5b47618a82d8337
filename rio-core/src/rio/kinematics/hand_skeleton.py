"""The tracked human hand RIO retargets from: its 25 joints, in one order shared by hand-tracking devices
(`rio.interfaces.teleop`), the retargeter (`rio.kinematics.hand_retarget`) and recorded episodes."""

from __future__ import annotations

#: A tracked hand's 25 joints, the order of WebXR's XRHand and visionOS's HandSkeleton.
HAND_JOINTS: tuple[str, ...] = (
    "wrist",
    "thumb-metacarpal", "thumb-phalanx-proximal", "thumb-phalanx-distal", "thumb-tip",
    *(f"{finger}-{part}" for finger in ("index-finger", "middle-finger", "ring-finger", "pinky-finger")
      for part in ("metacarpal", "phalanx-proximal", "phalanx-intermediate", "phalanx-distal", "tip")),
)
