"""`FaultHolder` and `LinkSupervisor`: a fault the hardware reports holds the node alive and disabled, names
itself in refusals and samples, and clears through the driver's hook back to holding where the device is;
a dropped link is held the same way and comes back holding."""

from __future__ import annotations

import numpy as np
import pytest

from rio import clock
from rio.errors import InvalidRequest
from rio.fakes.arms import FakeArm
from rio.interfaces import Fault, FaultHolder, LinkSupervisor
from rio.testing import lifecycle

COLLISION = Fault(31, "collision", "the arm hit something", "clear the obstacle", tag="C31")


class HoldingArm(FakeArm):
    """The fake arm with a hardware fault register: `hw_fault` is what the device reports now."""

    hw_fault: Fault | None = None
    cleared = 0

    def setup(self) -> None:
        super().setup()
        self.faults = FaultHolder(self, "the fake arm", ask=self.device_fault, clear=self.clear_device_faults)

    def read_joints(self):
        if self.hw_fault is not None and self.faults.fault is None:
            self.faults.report(self.hw_fault)
        return super().read_joints()

    def device_fault(self) -> Fault | None:
        return self.hw_fault

    def clear_device_faults(self) -> None:
        self.cleared += 1
        self.hw_fault = None


def request(q) -> dict:
    return {"mode": 0, "joint_pos": np.asarray(q, float), "eef_pose": np.zeros(7), "t_cmd_target": clock.now()}


def test_a_fault_holds_names_itself_and_clears():
    with lifecycle(HoldingArm(dof=3)) as arm:
        assert arm.cycle()["fault_code"] == 0 and arm.enabled
        arm.hw_fault = COLLISION
        s = arm.cycle()
        assert s["fault_code"] == 31 and not s["enabled"] and arm.faults.fault is COLLISION
        with pytest.raises(InvalidRequest, match="C31 collision: the arm hit something; clear the obstacle"):
            arm.handle_request(request([0.1, 0.0, 0.0]))
        with pytest.raises(InvalidRequest, match="C31 collision"):
            arm.enable()  # the device still reports it
        assert arm.fault_info() == COLLISION.as_dict()
        held = arm.cycle()["joint_pos"].copy()
        assert arm.clear_faults() == "cleared" and arm.cleared == 1
        s = arm.cycle()
        assert s["enabled"] and s["fault_code"] == 0 and arm.fault_info() is None
        np.testing.assert_allclose(s["joint_pos"], held)
        arm.handle_request(request([0.1, 0.0, 0.0]))  # accepted again


class LinkedArm(HoldingArm):
    """The holding arm behind a link that can drop: `up` is whether it answers; it reconnects itself as
    soon as `up` is true again (a driver would retry once a second)."""

    up = True
    seen_up = True

    def setup(self) -> None:
        super().setup()
        self.link = LinkSupervisor(self.faults, up=lambda: self.seen_up, reconnect=self.reconnect)

    def reconnect(self) -> None:
        self.seen_up = self.up

    def read_joints(self):
        if not self.up:
            self.seen_up = False  # the device stopped answering: the driver sees its link down
        self.link.watch()
        return super().read_joints()


def test_a_dropped_link_holds_refuses_and_comes_back_holding():
    with lifecycle(LinkedArm(dof=3)) as arm:
        assert arm.cycle()["connected"]
        arm.up = False
        s = arm.cycle()
        assert not s["connected"] and not s["enabled"] and s["fault_code"] == 0
        with pytest.raises(InvalidRequest, match="is down"):
            arm.handle_request(request([0.1, 0.0, 0.0]))
        with pytest.raises(InvalidRequest, match="nothing to clear"):
            arm.clear_faults()
        arm.up = True
        s = arm.cycle()
        assert s["connected"] and arm.enabled
        arm.handle_request(request([0.1, 0.0, 0.0]))  # accepted again


def test_a_link_that_comes_back_with_a_fault_holds_the_fault():
    with lifecycle(LinkedArm(dof=3)) as arm:
        arm.up = False
        arm.cycle()
        arm.hw_fault = COLLISION  # what the device reports once it answers again
        arm.up = True
        s = arm.cycle()
        assert s["connected"] and not arm.enabled and s["fault_code"] == 31
        assert arm.clear_faults() == "cleared" and arm.enabled


def test_a_node_disabled_when_the_link_dropped_stays_disabled():
    with lifecycle(LinkedArm(dof=3, enable_on_open=False)) as arm:
        arm.up = False
        arm.cycle()
        arm.up = True
        assert arm.cycle()["connected"] and not arm.enabled


class FlappingArm(LinkedArm):
    """A link that drops again in the instant between the driver seeing it up and the node enabling (CI
    saw it on the UR emulator: a sample read raised "the link is down" out of `read_state`): here while the
    device is asked for its fault on the way back."""

    flaps = 0

    def device_fault(self) -> Fault | None:
        if self.flaps:
            self.flaps -= 1
            self.seen_up = False  # gone again while enabling
        return super().device_fault()


def test_a_link_that_drops_again_while_coming_back_holds_then_comes_back():
    with lifecycle(FlappingArm(dof=3)) as arm:
        arm.up = False
        arm.cycle()
        arm.up, arm.flaps = True, 1
        s = arm.cycle()  # never raises: a sample read holds and says so
        assert not s["enabled"] and not arm.enabled
        s = arm.cycle()  # the link is seen up again: enabled this time
        assert s["connected"] and arm.enabled
        arm.handle_request(request([0.1, 0.0, 0.0]))


def test_the_drivers_hook_runs_once_the_fault_has_stopped_the_node():
    seen = []
    arm = HoldingArm(dof=3)
    arm.faults = FaultHolder(arm, "the fake arm", ask=arm.device_fault,
                             on_report=lambda fault: seen.append((fault, arm.enabled)))
    with lifecycle(arm):
        arm.cycle()
        arm.hw_fault = COLLISION
        arm.cycle()
        arm.cycle()  # held: not reported again
    assert seen == [(COLLISION, False)]


def test_the_old_mixin_names_say_what_to_write_instead():
    with pytest.raises(ImportError, match="FaultHolder"):
        from rio.interfaces import FaultHolding  # noqa: F401
    with pytest.raises(ImportError, match="ModelTable"):
        from rio.interfaces import ModelTableArm  # noqa: F401
