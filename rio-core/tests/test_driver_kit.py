"""The driver conformance kit is shipped with the pytest plugin and catches broken drivers.

Broken variants of the core fakes run through the kit with pytester: one publishes a wrong shape,
one publishes a made-up constant end-effector pose, one bypasses the kind's commander (no clipping,
no step limit, no watchdog). The cases that check what each breaks fail, naming the contract rule,
while the unbroken fakes pass the same run.
"""

from __future__ import annotations

import pytest

import rio.conformance.drivers  # noqa: F401 - loaded before the in-process pytester runs, which keep it
from rio.fakes.arms import FakeModelArm
from rio.plugins import get_registry
from rio.testing import lifecycle

from .conftest import kit_outcomes

pytest_plugins = ["pytester"]

BROKEN_DRIVERS = '''
import numpy as np
from rio import clock
from rio.errors import InvalidRequest
from rio.fakes.arms import FakeArm, FakeGripper, FakeModelArm


class WrongShapeGripper(FakeGripper):
    """Declares its finger force as one value but publishes one per finger."""

    def setup(self):
        super().setup()
        self.example_data = {**self.example_data, "finger_force": 0.0}

    def read_width(self):
        return {**super().read_width(), "finger_force": np.zeros(2)}


class ConstantPoseArm(FakeModelArm):
    """Reports a made-up end-effector pose (always the same) instead of NaN or forward kinematics."""

    def read_joints(self):
        return {"joint_pos": self.q.copy(), "eef_pose": np.array([0.3, 0.0, 0.2, 1.0, 0.0, 0.0, 0.0])}


class UnguardedArm(FakeArm):
    """Bypasses the kind's commander: each target goes straight to the hardware's own interpolator,
    unclipped, unlimited in step, never held when commands stop, resumed after a disable."""

    plan = None

    def command_joints(self, joint_pos, t_cmd_target):
        if not self.enabled:
            raise InvalidRequest(self.name, "joint_pos", "the device is disabled")
        self.plan = (self.q.copy(), np.array(joint_pos, dtype=float), clock.now(), float(t_cmd_target))

    def cycle(self):
        sample = self.read_arm()
        if self.enabled and self.plan is not None:
            q0, q1, t0, t1 = self.plan
            a = 1.0 if t1 <= t0 else min(max((clock.now() - t0) / (t1 - t0), 0.0), 1.0)
            self.write_joints(q0 + a * (q1 - q0))
        return self.complete(sample)

'''

KIT_RUN = '''
from broken_drivers import ConstantPoseArm, UnguardedArm, WrongShapeGripper
from rio.conformance.drivers import ArmConformance, GripperConformance

LIMITS = [(-1.5, 1.5), (-1.0, 2.0), (-2.0, 0.5)]
FAST = {"watchdog_s": 0.2}  # the watchdog case waits watchdog_s: keep the run short


class TestSoundArm(ArmConformance):
    driver = "rio.fake_arm"
    config = {"dof": 3, "joint_limits": LIMITS, **FAST}


class TestSoundModelArm(ArmConformance):
    driver = "rio.fake_model_arm"
    config = {"joint_limits": [(-3.0, 3.0), (-2.0, 2.0), (-2.5, 2.5), (-3.0, 3.0), (-2.0, 2.0), (-3.0, 3.0)], **FAST}


class TestSoundGripper(GripperConformance):
    driver = "rio.fake_gripper"
    config = FAST


class TestWrongShape(GripperConformance):
    driver = WrongShapeGripper
    config = FAST


class TestConstantPose(ArmConformance):
    driver = ConstantPoseArm
    config = FAST


class TestUnguarded(ArmConformance):
    driver = UnguardedArm
    config = {"dof": 3, "joint_limits": LIMITS, **FAST}


class TestWrongKit(GripperConformance):
    driver = "rio.fake_arm"
'''

ARM_CASES = 12
GRIPPER_CASES = 11
STARTUP = "test_startup_failure_names_the_node"  # skipped: these fakes have no bad_config
MOTION = {"test_targets_beyond_the_limit_end_at_the_limit", "test_a_far_target_moves_at_most_max_step_per_cycle",
          "test_a_silent_stream_is_held_by_the_watchdog", "test_disabled_refuses_commands_and_enable_holds_the_pose"}


def _failed(results: dict[str, str]) -> set[str]:
    return {c for c, o in results.items() if o in ("failed", "error")}


@pytest.fixture(scope="module")
def kit_loaded() -> None:
    """An in-process pytester run forgets the modules first imported during it (pytester snapshots
    sys.modules when its fixture starts), but the `rio` package keeps its attributes for them: a later
    `from . import builtin_plugin` would get the forgotten module (whose `Spec` is not `rio.plugins.specs.Spec`
    any more), and an extension module cannot be loaded twice. Loading them before, in a fixture of a
    wider scope than pytester's, keeps them."""
    get_registry().specs("rio_drivers")  # rio.plugins, the core's and the installed plugins' modules
    import rio.middleware.thread  # noqa: F401 - served cases
    import rio.runtime.runner  # noqa: F401 - the close-after-error case

    with lifecycle(FakeModelArm()) as arm:  # forward kinematics: rio.kinematics and what it imports
        arm.cycle()


@pytest.mark.slow
def test_kit_catches_broken_drivers_and_passes_the_sound_fakes(kit_loaded: None, pytester: pytest.Pytester):
    pytester.makepyfile(broken_drivers=BROKEN_DRIVERS, test_broken_drivers=KIT_RUN)
    pytester.syspathinsert()  # the broken drivers are importable by name, like a plugin's
    res = kit_outcomes(pytester.inline_run("-p", "no:cacheprovider"))

    for cls, n in (("TestSoundArm", ARM_CASES), ("TestSoundModelArm", ARM_CASES), ("TestSoundGripper", GRIPPER_CASES)):
        assert len([c for c in res[cls] if not c.endswith(" text")]) == n, (cls, res[cls])
        assert {c for c, o in res[cls].items() if o != "passed"} == {STARTUP}, (cls, res[cls])
        assert res[cls][STARTUP] == "skipped"

    # a wrong shape: the layout case names the field and both shapes
    shape = res["TestWrongShape"]
    assert shape["test_samples_match_the_declared_layout"] == "failed"
    text = shape["test_samples_match_the_declared_layout text"]
    assert "gripper contract, every sample has exactly the keys, shapes and dtypes declared in example_data" in text
    assert "'finger_force' has shape (2,), example_data declares ()" in text
    # the runtime refuses such a sample, so the cases that serve the node fail too (the node dies at its
    # first publish); the cases run in the test's thread see nothing else wrong
    assert _failed(shape) == {"test_samples_match_the_declared_layout", "test_served_by_the_runtime",
                              "test_close_runs_after_an_error_mid_run", "test_bad_requests_are_rejected_by_name"}, shape
    assert "InvalidRequest: node 'gripper_under_test': field 'finger_force': expected shape ()" in \
        shape["test_close_runs_after_an_error_mid_run text"]
    assert ("gripper contract, the node serves its samples through the runtime: the node did not start under the "
            "runtime: node 'gripper_under_test' failed to start") in shape["test_served_by_the_runtime text"]

    # a made-up constant pose: only the case that moves the joints and watches the pose sees it
    const = res["TestConstantPose"]
    assert _failed(const) == {"test_eef_pose_follows_the_joints"}, const
    text = const["test_eef_pose_follows_the_joints text"]
    assert "arm contract, NaN for unmeasured values: a finite eef_pose follows the joints" in text
    assert "eef_pose stayed at [0.3 0.  0.2 1.  0.  0.  0. ]" in text

    # around the commander: every safety case fails, each for its own rule
    unguarded = res["TestUnguarded"]
    assert _failed(unguarded) == MOTION, unguarded
    texts = {c: unguarded[f"{c} text"] for c in MOTION}
    assert ("arm contract, limit clipping: a target beyond a limit ends at the limit, never beyond: joint 0: goal "
            "2.5000 rad written beyond the upper limit 1.5000") in \
        texts["test_targets_beyond_the_limit_end_at_the_limit"]
    assert "arm contract, maximum step: the goal moves at most max_step per cycle" in \
        texts["test_a_far_target_moves_at_most_max_step_per_cycle"]
    assert "arm contract, watchdog hold" in texts["test_a_silent_stream_is_held_by_the_watchdog"]
    assert "arm contract, enable holds the present pose" in \
        texts["test_disabled_refuses_commands_and_enable_holds_the_pose"]

    # the wrong kit for the driver's kind: every case errors, saying which kit to use
    wrong = res["TestWrongKit"]
    assert {o for c, o in wrong.items() if not c.endswith(" text")} == {"error"}, wrong
    assert ("rio.fake_arm is registered as a arm driver; test it with ArmConformance, not GripperConformance"
            in wrong["test_samples_match_the_declared_layout text"])


@pytest.mark.slow
def test_rio_driver_option_runs_the_kit_of_its_kind_without_a_file(pytester: pytest.Pytester):
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "--rio-driver", "rio.fake_gripper",
                                           "--rio-driver-config", '{"max_width": 0.06, "max_step_m": 0.02}')
    result.stdout.fnmatch_lines(["rio: driver conformance kit on 'rio.fake_gripper' with {\"max_width\": 0.06, *}"])
    outcomes = result.parseoutcomes()
    assert outcomes.get("passed") == GRIPPER_CASES - 1 and "failed" not in outcomes and "errors" not in outcomes, \
        outcomes
