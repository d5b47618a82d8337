"""Damping safety (`rio.interfaces.damping`): the tilt of a base from its IMU, the three named stops of a
driver that holds a `DampingGuard` (state lost, fall, stale stream) and damping every cycle while
disabled, and the driver kit's watchdog case asking the driver whether to expect a damping stop.

`SoftHumanoid` is a stand-in for a humanoid on low-level topics (its joints follow the goal; a test
silences its state, tilts its IMU, and counts the damping commands it would send)."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from pydantic import Field

from rio import clock
from rio.conformance.driver_base import WATCHDOG, WATCHDOG_DAMPS
from rio.conformance.drivers import HumanoidConformance
from rio.conformance.driving import Loop, build_node, resolve_driver
from rio.control.rotations import euler_to_quat
from rio.errors import InvalidRequest
from rio.interfaces import BodyDampingConfig, DampingGuard, FaultHolder, HumanoidNode
from rio.interfaces.damping import FALL, STALE_COMMANDS, STATE_LOST, state_lost, tilt_from_quat, tilt_from_rpy
from rio.testing import lifecycle


class SoftHumanoid(HumanoidNode):
    class Config(BodyDampingConfig, HumanoidNode.Config):
        rate_hz: float = Field(100.0, gt=0)
        dof: int = Field(4, ge=1)
        max_step_rad: float = Field(0.5, gt=0)

    def default_joint_names(self) -> list[str]:
        return [f"joint{i + 1}" for i in range(self.config.dof)]

    def setup(self) -> None:
        super().setup()
        self.safety = DampingGuard(self, self.state_lost, tilt=self.tilt_deg, body="pelvis")
        self.faults = FaultHolder(self, "the soft humanoid", ask=self.safety.device_fault)
        self.silent = False  # the device stops publishing
        self.quat = np.array([1.0, 0.0, 0.0, 0.0])
        self.dampings = 0

    def open(self) -> None:
        self.q = np.zeros(self.dof)

    def state_lost(self, age: float):
        return state_lost("softstate_timeout", "soft/state", age, "the test", "unsilence it")

    def tilt_deg(self) -> float | None:
        return tilt_from_quat(self.quat)

    def write_disabled(self) -> None:
        self.dampings += 1

    def read_joints(self) -> dict:
        if not self.silent:
            self.safety.t_state = clock.now()
        self.safety.watch()
        return {"joint_pos": self.q.copy(), "joint_vel": np.zeros(self.dof), "base_quat": self.quat.copy(),
                "base_ang_vel": np.zeros(3)}

    def write_joints(self, joint_pos: np.ndarray) -> None:
        self.q = np.array(joint_pos, dtype=np.float64)


class StiffLiar(SoftHumanoid):
    """Says it damps a silent stream but only holds it (what the kit must catch)."""

    def setup(self) -> None:
        super().setup()
        self.safety.watch = lambda: None  # watches nothing: never stops itself


def soft(**fields) -> SoftHumanoid:
    return build_node(resolve_driver(SoftHumanoid), {"watchdog_s": 0.1, **fields}, "soft")


def stream_then_stop(node, loop: Loop) -> None:
    """A policy streaming toward a target still far ahead, then silence."""
    now = clock.now()
    for dt in (0.02, 0.04):
        node.handle_request({"joint_pos": np.full(node.dof, 0.5), "t_cmd_target": now + 5.0 + dt})
        loop.tick()


# -- tilt ---------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("roll", "pitch", "yaw", "tilt"), [(0, 0, 0, 0), (0, 30, 80, 30), (-45, 0, -170, 45),
                                                            (0, 90, 0, 90), (180, 0, 20, 180)])
def test_tilt_is_the_up_axis_angle_and_ignores_yaw(roll, pitch, yaw, tilt):
    q = euler_to_quat(*np.radians([roll, pitch, yaw]))
    assert tilt_from_quat(q) == pytest.approx(tilt, abs=1e-6)
    assert tilt_from_quat(3.0 * q) == pytest.approx(tilt, abs=1e-6)  # an IMU's quaternion need not be unit
    assert tilt_from_rpy(np.radians([roll, pitch, yaw])) == pytest.approx(tilt, abs=1e-6)


def test_tilt_from_rpy_agrees_with_the_quaternion_on_random_poses():
    rng = np.random.default_rng(3)
    for rpy in rng.uniform(-math.pi, math.pi, (50, 3)):
        assert tilt_from_rpy(rpy) == pytest.approx(tilt_from_quat(euler_to_quat(*rpy)), abs=1e-6)


def test_an_imu_reading_that_means_nothing_is_nan_never_upright():
    for q in ([0, 0, 0, 0], [np.nan, 0, 0, 1], [np.inf, 0, 0, 0]):
        assert math.isnan(tilt_from_quat(q))
    assert math.isnan(tilt_from_rpy([np.nan, 0.0, 0.0]))


# -- the stops ----------------------------------------------------------------------------------------------
def test_a_stream_that_stops_is_a_stale_fault_and_damped_every_cycle():
    node = soft()
    assert node.safety.damps_on_stale  # the default
    with lifecycle(node):
        loop = Loop(node)
        stream_then_stop(node, loop)
        s = loop.run(until=lambda s: s["fault_code"] != 0, timeout=3.0)
        assert s["fault_code"] == STALE_COMMANDS and not s["enabled"] and node.faults.fault.name == "stale_commands"
        n = node.dampings
        loop.run(cycles=5)
        assert node.dampings >= n + 5  # every cycle while faulted
        with pytest.raises(InvalidRequest, match="stale_commands"):
            node.handle_request({"joint_pos": np.zeros(node.dof), "t_cmd_target": clock.now()})
        node.clear_faults()
        s = loop.run(cycles=3)
        assert s["enabled"] and s["fault_code"] == 0
        n = node.dampings
        loop.run(cycles=3)
        assert node.dampings == n  # enabled: no damping


def test_with_on_stale_hold_a_stream_that_stops_is_held_stiff():
    node = soft(on_stale="hold")
    with lifecycle(node):
        loop = Loop(node)
        stream_then_stop(node, loop)
        loop.run(seconds=0.4)
        s = loop.last
        assert s["enabled"] and s["holding"] and s["fault_code"] == 0 and node.dampings == 0


def test_a_silent_device_is_the_drivers_named_fault_until_it_speaks_again():
    node = soft(state_timeout_s=0.1)
    with lifecycle(node):
        loop = Loop(node)
        loop.run(cycles=3)
        node.silent = True
        s = loop.run(until=lambda s: s["fault_code"] != 0, timeout=3.0)
        assert s["fault_code"] == STATE_LOST and node.faults.fault.name == "softstate_timeout" and not s["enabled"]
        assert "no soft/state for" in str(node.faults.fault) and "unsilence it" in str(node.faults.fault)
        with pytest.raises(InvalidRequest, match="softstate_timeout"):
            node.clear_faults()  # refused while it lasts
        node.silent = False
        loop.run(cycles=2)
        node.clear_faults()
        assert loop.run(cycles=2)["enabled"]


def test_the_drivers_own_stall_is_not_the_devices_silence():
    """The driver's process stalled 0.3 s (a loaded host; an in-process emulator's stream stalled with it):
    its first cycle after, before the device's next state is in, counts only a bounded share of the stall,
    not a state_timeout_s of 0.1 s. Silence while the driver runs still faults (the test above)."""
    node = soft(state_timeout_s=0.1)
    with lifecycle(node):
        loop = Loop(node)
        loop.run(cycles=3)
        node.silent = True  # no state gets in while the process is stalled ...
        time.sleep(0.3)
        s = loop.tick()  # ... nor in the cycle it resumes with
        assert s["fault_code"] == 0 and s["enabled"], node.faults.fault
        assert node.safety.state_age(clock.now()) < 0.1
        node.silent = False
        assert loop.run(cycles=2)["fault_code"] == 0


def test_a_fall_faults_beyond_the_limit_only_and_holds_over_a_later_stale_stream():
    node = soft(fall_tilt_deg=40.0)
    with lifecycle(node):
        loop = Loop(node)
        node.quat = euler_to_quat(0.0, math.radians(35.0), 1.0)
        assert loop.run(cycles=3)["fault_code"] == 0
        node.quat = euler_to_quat(math.radians(50.0), 0.0, 0.0)
        s = loop.run(until=lambda s: s["fault_code"] != 0, timeout=3.0)
        assert s["fault_code"] == FALL and "pelvis is tilted 50 deg" in str(node.faults.fault)
        loop.run(cycles=3)
        assert node.faults.fault.code == FALL  # a fall is not replaced by anything watched later
        with pytest.raises(InvalidRequest, match="fall"):
            node.clear_faults()
        node.quat = np.array([1.0, 0.0, 0.0, 0.0])
        node.clear_faults()
        assert loop.run(cycles=2)["enabled"]


def test_fall_tilt_none_turns_the_fall_check_off():
    node = soft(fall_tilt_deg=None)
    with lifecycle(node):
        node.quat = euler_to_quat(math.pi, 0.0, 0.0)  # upside down
        assert Loop(node).run(cycles=3)["fault_code"] == 0


# -- the kit ------------------------------------------------------------------------------------------------
class TestSoftHumanoidDamps(HumanoidConformance):
    """The whole humanoid kit on a driver that damps (its default): the watchdog case checks the stop."""

    driver = SoftHumanoid
    config = {"joint_limits": [(-1.0, 1.0)] * 4}


class TestSoftHumanoidHolds(HumanoidConformance):
    driver = SoftHumanoid
    config = {"joint_limits": [(-1.0, 1.0)] * 4, "on_stale": "hold"}


class _Kit(HumanoidConformance):
    driver = SoftHumanoid


class _KitToldHold(_Kit):
    on_stale = "hold"


@pytest.mark.parametrize(("kit", "driver", "rule"), [(_Kit, StiffLiar, WATCHDOG_DAMPS),
                                                     (_KitToldHold, SoftHumanoid, WATCHDOG)])
def test_the_kit_fails_a_driver_that_does_not_do_what_is_expected_of_a_silent_stream(kit, driver, rule):
    """A driver saying it damps but holding stiff fails the damping check; a driver that damps where the
    test expects a hold fails the hold check."""
    fields = {"joint_limits": [(-1.0, 1.0)] * 4}
    with pytest.raises(AssertionError, match=rule.split(":")[0]):
        kit().test_a_silent_stream_is_held_by_the_watchdog(resolve_driver(driver), fields)


def test_motor_gains_take_the_config_per_joint_or_the_drivers_table_and_name_a_wrong_length():
    from rio.interfaces import MotorGainsConfig, motor_gains

    table = {"kp": [100.0, 50.0], "kd": [2.0, 1.0], "damping_kd": [1.0, 0.5]}
    got = motor_gains(MotorGainsConfig(kd=[3.0, 4.0]), table, "g1", 2)
    assert got == {"kp": [100.0, 50.0], "kd": [3.0, 4.0], "damping_kd": [1.0, 0.5]}
    with pytest.raises(ValueError, match="kp has 3 values; node 'g1' drives 2 joints"):
        motor_gains(MotorGainsConfig(kp=[1.0, 2.0, 3.0]), table, "g1", 2)
