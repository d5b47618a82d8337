"""The SO-100 and SO-101 arms as the bus sees them: which servo id drives which joint.

Both arms use six STS3215 servos, ids 1-5 for the arm joints (base to wrist) and 6 for the jaw, so
the follower, gripper and leader drivers are the same code for both; the model name selects the
calibration folder and is what a station or dataset records. (The SO-101 leader's gear ratios differ
from its follower's, which calibration absorbs: joint angles are measured at the output.)
"""

from __future__ import annotations

from dataclasses import dataclass

ARM_JOINTS = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll")
GRIPPER = "gripper"
ARM_IDS = (1, 2, 3, 4, 5)
GRIPPER_ID = 6


@dataclass(frozen=True)
class ArmModel:
    name: str
    description: str
    #: Jaw opening reported as the gripper's full width (m), matching rio-sim's SO-100 model.
    max_width: float = 0.06


MODELS = {
    "so100": ArmModel("so100", "SO-100 (SO-ARM100) arm, six Feetech STS3215 servos"),
    "so101": ArmModel("so101", "SO-101 (SO-ARM101) arm, six Feetech STS3215 servos"),
}


def joint_names(ids) -> dict[int, str]:
    """Default joint name of each SO-arm servo id (for messages and calibration files)."""
    names = dict(zip(ARM_IDS, ARM_JOINTS, strict=True))
    names[GRIPPER_ID] = GRIPPER
    return {int(i): names.get(int(i), f"joint{i}") for i in ids}
