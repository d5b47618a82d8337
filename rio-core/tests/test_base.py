"""The mobile base kind: its safety (`TwistCommander`), kinematics and odometry, the conformance kit on the
fake base, and the MobileManipulator embodiment on a station of fakes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rio.conformance.drivers import BaseConformance
from rio.control.odometry import PlanarOdometry, advance
from rio.control.omni import OmniKinematics
from rio.control.twist_commander import TwistCommander


class TestFakeBase(BaseConformance):
    driver = "rio.fake_base"


class TestFrozenBaseFailsTheKit:
    """The kit can fail: a base that ignores its commands does not follow the odometry case."""

    def test_frozen_base_fails_odometry(self):
        from rio.conformance.driving import resolve_driver
        from rio.conformance.mobile import BaseConformance as Kit

        kit = Kit()
        with pytest.raises(AssertionError, match="did not move forward"):
            kit.test_odometry_follows_a_straight_drive(resolve_driver("rio.fake_base"), {"frozen": True})


def test_commander_limits_speed_and_acceleration():
    c = TwistCommander(0.3, 1.0, 1.0, 2.0, rate_hz=50.0, watchdog_s=0.3)
    t = 0.0
    c.command([5.0, 5.0, -9.0], t, t)
    prev = np.zeros(3)
    for _ in range(100):
        t += 0.02
        c.command([5.0, 5.0, -9.0], t, t)
        g = c.step(t)
        assert math.hypot(*(g - prev)[:2]) <= 1.0 / 50 + 1e-12 and abs((g - prev)[2]) <= 2.0 / 50 + 1e-12
        prev = g
    assert math.hypot(g[0], g[1]) == pytest.approx(0.3) and g[0] == pytest.approx(g[1])  # direction kept
    assert g[2] == pytest.approx(-1.0)


def test_commander_watchdog_ramps_to_a_stop_after_watchdog_s():
    c = TwistCommander(0.5, 1.0, 1.0, 2.0, rate_hz=100.0, watchdog_s=0.2)
    t = 0.0
    for _ in range(100):
        t += 0.01
        c.command([0.4, 0.0, 0.0], t, t)
        c.step(t)
    assert c.goal[0] == pytest.approx(0.4) and not c.holding
    t_last = t
    stopped_at = slowed_at = None
    while t < t_last + 1.5:
        t += 0.01
        g = c.step(t)
        if slowed_at is None and g[0] < 0.4 - 1e-12:
            slowed_at = t - t_last
        if stopped_at is None and g[0] == 0.0:
            stopped_at = t - t_last
    assert 0.2 <= slowed_at <= 0.2 + 0.011  # not before watchdog_s
    assert stopped_at == pytest.approx(0.2 + 0.4 / 1.0, abs=0.02)  # then a ramp at the acceleration limit
    assert c.holding and c.watchdog_holds == 1


def test_omni_kinematics_round_trip_and_wheel_directions():
    kin = OmniKinematics.from_degrees([150.0, -90.0, 30.0], 0.05, 0.125)
    twist = np.array([0.2, -0.1, 0.7])
    assert np.allclose(kin.to_body(kin.to_wheels(twist)), twist)
    # a pure spin turns every wheel the same way at R * wz / r
    assert np.allclose(kin.to_wheels([0.0, 0.0, 1.0]), 0.125 / 0.05)
    # straight ahead: the back wheel (pushing along -y) does not turn, the front two turn opposite ways
    w = kin.to_wheels([0.1, 0.0, 0.0])
    assert abs(w[1]) < 1e-12 and w[0] == pytest.approx(-w[2])
    with pytest.raises(ValueError, match="holonomic"):
        OmniKinematics.from_degrees([0.0, 180.0, 0.0], 0.05, 0.1)


def test_odometry_closes_a_circle_with_coarse_samples():
    odo = PlanarOdometry()
    v, w = 0.2, 2 * math.pi / 4.0  # one turn in 4 s
    for k in range(9):  # samples every 0.5 s: an Euler step would miss the circle by centimeters
        odo.update([v, 0.0, w], 0.5 * k)
    assert np.allclose(odo.pose, [0.0, 0.0, 0.0], atol=1e-9)
    quarter = advance([0.0, 0.0, 0.0], [v, 0.0, w], 1.0)
    r = v / w
    assert np.allclose(quarter, [r, r, math.pi / 2])
