"""Fake devices behind the standard kinds (`rio.interfaces`): in-process stand-ins with no hardware and no
simulator, registered by the core as the `rio.fake_*` drivers so that stations, embodiments, docs examples
and generated plugins can be exercised anywhere.

Each one's hardware follows the goal it is written at once: the kind's commander (interpolation, limits,
step limit, watchdog) is what makes it move smoothly, exactly as on a real driver. The ones with a
kinematic model (`FakeModelArm`, `FakeModelHand`, `FakeModelHumanoid`) carry small MJCF models written
from tables, for retargeting and IK tests. Test *nodes* that are no device kind (counters, echoes) are in
`rio.testing`.
"""

from rio.fakes.arms import SIX_DOF_MJCF, FakeArm, FakeGripper, FakeModelArm
from rio.fakes.base import FakeBase
from rio.fakes.hands import FIVE_FINGER_HAND_MJCF, FakeHand, FakeModelHand
from rio.fakes.humanoid import UPPER_BODY_MJCF, FakeHumanoid, FakeModelHumanoid
from rio.fakes.sensors import FakeCamera, FakeSensor
from rio.fakes.teleop import FakeHandTracker, FakeTeleop, synthetic_hand_keypoints

__all__ = ["FakeArm", "FakeBase", "FakeModelArm", "FakeGripper", "FakeCamera", "FakeSensor", "FakeTeleop",
           "FakeHandTracker", "FakeHand", "FakeModelHand", "FakeHumanoid", "FakeModelHumanoid", "SIX_DOF_MJCF",
           "FIVE_FINGER_HAND_MJCF", "UPPER_BODY_MJCF", "synthetic_hand_keypoints"]
