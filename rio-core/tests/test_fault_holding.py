"""`FaultHolding`: a fault the hardware reports holds the node alive and disabled, names itself in
refusals and samples, and clears through the driver's hook back to holding where the device is."""

from __future__ import annotations

import numpy as np
import pytest

from rio import clock
from rio.errors import InvalidRequest
from rio.fakes.arms import FakeArm
from rio.interfaces import FAULT_KEYS, Fault, FaultHolding
from rio.testing import lifecycle

COLLISION = Fault(31, "collision", "the arm hit something", "clear the obstacle", tag="C31")


class HoldingArm(FaultHolding, FakeArm):
    """The fake arm with a hardware fault register: `hw_fault` is what the device reports now."""

    hw_fault: Fault | None = None
    cleared = 0

    def setup(self) -> None:
        super().setup()
        self.example_data = {**self.example_data, **FAULT_KEYS}

    def read_joints(self):
        if self.hw_fault is not None and self.fault is None:
            self.on_fault(self.hw_fault)
        return {**super().read_joints(), **self.fault_status()}

    def set_enabled(self, enabled: bool) -> None:
        if enabled:
            self.check_device_fault()
        super().set_enabled(enabled)

    def device_fault(self) -> Fault | None:
        return self.hw_fault

    def clear_device_faults(self) -> None:
        self.cleared += 1
        self.hw_fault = None


def request(q) -> dict:
    return {"mode": 0, "joint_pos": np.asarray(q, float), "eef_pose": np.zeros(7), "t_cmd_target": clock.now()}


def test_a_fault_holds_names_itself_and_clears():
    with lifecycle(HoldingArm(dof=3)) as arm:
        assert arm.read_state()["fault_code"] == 0 and arm.enabled
        arm.hw_fault = COLLISION
        s = arm.read_state()
        assert s["fault_code"] == 31 and not s["enabled"] and arm.fault is COLLISION
        with pytest.raises(InvalidRequest, match="C31 collision: the arm hit something; clear the obstacle"):
            arm.handle_request(request([0.1, 0.0, 0.0]))
        with pytest.raises(InvalidRequest, match="C31 collision"):
            arm.enable()  # the device still reports it
        assert arm.fault_info() == COLLISION.as_dict()
        held = arm.read_state()["joint_pos"].copy()
        assert arm.clear_faults() == "cleared" and arm.cleared == 1
        s = arm.read_state()
        assert s["enabled"] and s["fault_code"] == 0 and arm.fault_info() is None
        np.testing.assert_allclose(s["joint_pos"], held)
        arm.handle_request(request([0.1, 0.0, 0.0]))  # accepted again


class LinkedArm(HoldingArm):
    """The holding arm behind a link that can drop: `up` is whether it answers; it reconnects itself as
    soon as `up` is true again (a driver would retry once a second)."""

    up = True
    seen_up = True

    def link_up(self) -> bool:
        return self.seen_up

    def read_joints(self):
        if not self.up:
            self.seen_up = False
            self.on_lost()
        else:
            self.seen_up = True
            self.on_restored()
        return super().read_joints()


def test_a_dropped_link_holds_refuses_and_comes_back_holding():
    with lifecycle(LinkedArm(dof=3)) as arm:
        assert arm.read_state()["connected"]
        arm.up = False
        s = arm.read_state()
        assert not s["connected"] and not s["enabled"] and s["fault_code"] == 0
        with pytest.raises(InvalidRequest, match="is down"):
            arm.handle_request(request([0.1, 0.0, 0.0]))
        with pytest.raises(InvalidRequest, match="nothing to clear"):
            arm.clear_faults()
        arm.up = True
        s = arm.read_state()
        assert s["connected"] and arm.enabled
        arm.handle_request(request([0.1, 0.0, 0.0]))  # accepted again


def test_a_link_that_comes_back_with_a_fault_holds_the_fault():
    with lifecycle(LinkedArm(dof=3)) as arm:
        arm.up = False
        arm.read_state()
        arm.hw_fault = COLLISION  # what the device reports once it answers again
        arm.up = True
        s = arm.read_state()
        assert s["connected"] and not arm.enabled and s["fault_code"] == 31
        assert arm.clear_faults() == "cleared" and arm.enabled


def test_a_node_disabled_when_the_link_dropped_stays_disabled():
    with lifecycle(LinkedArm(dof=3, enable_on_open=False)) as arm:
        arm.up = False
        arm.read_state()
        arm.up = True
        assert arm.read_state()["connected"] and not arm.enabled


class FlappingArm(LinkedArm):
    """A link that drops again in the instant between the driver seeing it up and the node enabling (CI
    saw it on the UR emulator: a sample read raised "the link is down" out of `read_state`)."""

    flaps = 0

    def set_enabled(self, enabled: bool) -> None:
        if enabled and self.flaps:
            self.flaps -= 1
            self.seen_up = False  # gone again while enabling
        super().set_enabled(enabled)


def test_a_link_that_drops_again_while_coming_back_holds_then_comes_back():
    with lifecycle(FlappingArm(dof=3)) as arm:
        arm.up = False
        arm.read_state()
        arm.up, arm.flaps = True, 1
        s = arm.read_state()  # never raises: a sample read holds and says so
        assert not s["enabled"] and not arm.enabled
        s = arm.read_state()  # the link is seen up again: enabled this time
        assert s["connected"] and arm.enabled
        arm.handle_request(request([0.1, 0.0, 0.0]))
