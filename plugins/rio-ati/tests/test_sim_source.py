"""The emulated box measuring physics: its load is a running rio-sim world's wrist force/torque sensor, read
by the real driver through RDT. At rest the xArm7's wrist carries its gripper, 0.3168 kg: 3.11 N along the
site's z; the world's own `sim.wrench` agrees with what came over the wire."""

from __future__ import annotations

import uuid

import numpy as np
import pytest

pytest.importorskip("mujoco")

from rio_ati.driver import NetFTSensor  # noqa: E402
from rio_ati.emulator import NetFTBox  # noqa: E402
from rio_ati.emulator_node import EmulatorNode  # noqa: E402
from rio_ati.sim_source import WristSource  # noqa: E402
from rio_sim.world import SimWorld  # noqa: E402
from rio_sim.wrench import SimWrench  # noqa: E402

from rio import ServerManager, serve  # noqa: E402
from rio.testing import lifecycle, wait_until  # noqa: E402

GRIPPER_WEIGHT_N = 0.3168 * 9.81


def test_the_driver_reads_the_sim_wrist_through_the_box():
    world = f"ati-{uuid.uuid4().hex[:6]}"
    with ServerManager("thread", [serve(SimWorld, name="world", world=world, scene="xarm7")], station=world):
        source = WristSource(world, "arm")
        try:
            with NetFTBox(source=source, rate_hz=500.0) as box, \
                    lifecycle(NetFTSensor(ip=box.host, rdt_port=box.rdt_port, http_port=box.http_port)) as ft, \
                    lifecycle(SimWrench(world=world)) as wrist:
                got: dict = {}
                assert wait_until(lambda: got.update(ft.read_state() or {}) or "force" in got, timeout=10.0)
                s = wrist.read_state() or wrist.read_state()
        finally:
            source.close()
    f = np.asarray(got["force"])
    assert np.linalg.norm(f) == pytest.approx(GRIPPER_WEIGHT_N, abs=0.2), f  # counts: 1e6 per N, no noise
    assert f == pytest.approx(np.asarray(s["force"]), abs=0.05)


def test_the_emulator_node_takes_a_sim_backend_by_name():
    assert EmulatorNode(backend="sim:left@w").sim_target == ("left", "w")
    assert EmulatorNode().sim_target is None
    with pytest.raises(ValueError, match="neither"):
        EmulatorNode(backend="mujoco")
