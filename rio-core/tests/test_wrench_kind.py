"""The wrench kind (`rio.interfaces.WrenchNode`): the bias that tare() takes is subtracted from later
samples, a driver's malformed reading is an error naming the node, and the kit catches a driver whose
device tare does nothing."""

from __future__ import annotations

import numpy as np
import pytest

from rio.conformance.driving import build_node, resolve_driver
from rio.conformance.sensing import WrenchConformance
from rio.fakes.sensors import FakeWrench
from rio.testing import lifecycle


def test_tare_takes_the_mean_of_recent_readings_as_the_bias():
    node = FakeWrench(load=[3.0, 0.0, -9.8, 0.0, 0.2, 0.0], noise=0.0, tare_samples=4)
    with lifecycle(node):
        s = node.read_state()
        assert np.allclose(s["force"], [3.0, 0.0, -9.8]) and np.allclose(s["torque"], [0.0, 0.2, 0.0])
        for _ in range(4):
            node.read_state()
        assert np.allclose(node.tare(), [3.0, 0.0, -9.8, 0.0, 0.2, 0.0])
        node.config.load[2] = -19.6  # a 1 kg object picked up after the tare
        s = node.read_state()
        assert np.allclose(s["force"], [0.0, 0.0, -9.8]) and np.allclose(s["torque"], 0.0)
        node.untare()
        assert np.allclose(node.read_state()["force"], [3.0, 0.0, -19.6])


def test_tare_on_open_zeroes_the_first_full_window():
    node = FakeWrench(load=[0.0, 0.0, -5.0, 0.0, 0.0, 0.0], noise=0.0, tare_samples=3, tare_on_open=True)
    with lifecycle(node):
        forces = [node.read_state()["force"][2] for _ in range(4)]
    assert forces[:2] == [-5.0, -5.0] and forces[2:] == [0.0, 0.0]


def test_a_malformed_reading_names_the_node_and_key():
    class Bad(FakeWrench):
        def read_wrench(self):
            return {"force": [1.0, 2.0], "torque": [0.0, 0.0, 0.0]}

    node = Bad()
    node.name = "ft"
    with lifecycle(node), pytest.raises(ValueError, match="node 'ft'.*'force' with 2 values"):
        node.read_state()


def test_the_kit_fails_a_device_tare_that_does_not_bias():
    class Ignores(FakeWrench):
        def tare_device(self):
            return True  # claims the device biased itself; the readings still carry the load

    class Kit(WrenchConformance):
        driver = Ignores
        config = {"load": [0.0, 0.0, -9.8, 0.0, 0.0, 0.0], "noise": 0.0}

    kit, dut = Kit(), resolve_driver(Ignores)
    with pytest.raises(AssertionError, match="wrench contract, tare"):
        kit.test_tare_zeroes_an_unchanged_load(dut, dict(Kit.config))
    assert build_node(dut, dict(Kit.config), "w").config.tare_samples == 10
