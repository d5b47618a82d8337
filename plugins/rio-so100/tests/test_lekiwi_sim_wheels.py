"""LeKiwi's wheel driver (`lekiwi.base`) against rio-sim's physics (`port = "sim"`): the real driver, its
scservo_sdk packets, wheel mode and SYNC READ/WRITE, on an emulated bus whose wheels turn with the `lekiwi`
scene's base (`rio_so100.emulator.sim_base`). A twist streamed to the driver moves the simulated base that way,
and the wheel angles the driver reads over the bus account for where the base went in the world."""

from __future__ import annotations

import time

import numpy as np
import pytest

pytest.importorskip("rio_sim")
pytest.importorskip("mujoco")

from rio_sim.world_base import WorldBase  # noqa: E402
from rio_so100.emulator.sim_base import parse_sim_base_port  # noqa: E402
from rio_so100.lekiwi import geometry as G  # noqa: E402
from rio_so100.lekiwi.wheels import LeKiwiBase  # noqa: E402

from rio import clock  # noqa: E402
from rio.control.omni import OmniKinematics  # noqa: E402
from rio.runtime.manager import ServerManager, connect  # noqa: E402
from rio.station.build import make_station  # noqa: E402
from rio.station.load import parse_station  # noqa: E402


def test_parse_sim_base_port():
    assert parse_sim_base_port("sim") == ("base", "sim")
    assert parse_sim_base_port("sim:@w2") == ("base", "w2") and parse_sim_base_port("sim:b@w") == ("b", "w")
    assert parse_sim_base_port("emulator") is None


def drive(base, twist, seconds: float) -> None:
    """Stream `twist` at 20 Hz for `seconds` (the base kind's stop watchdog wants fresh commands)."""
    end = clock.now() + seconds
    while clock.now() < end:
        base.move_twist(twist, clock.now() + 0.05)
        time.sleep(0.05)


@pytest.mark.parametrize("mw", ["thread", "shm"])
def test_the_wheel_driver_drives_the_simulated_base(mw):
    world = f"lekiwi-wheels-{mw}"
    st = parse_station({"name": world, "rate_hz": 30, "middleware": {"name": mw},
                        "components": {"world_sensor": {"driver": "sim.world", "scene": "lekiwi", "world": world},
                                       "base": {"driver": "lekiwi.base", "port": f"sim:@{world}"}}}, source="<test>")
    servers, _clients, _env = make_station(st)
    with ServerManager(servers, station=world), connect(LeKiwiBase, mw, name="base", station=world) as base, \
            WorldBase.attach(world, "base", timeout=10.0) as truth:
        s0 = base.get_state()
        start, odom0, wheels0 = truth.pose(), np.asarray(s0["odom_pose"]).copy(), np.asarray(s0["wheel_pos"]).copy()
        drive(base, [0.1, 0.0, 0.0], 2.0)  # ahead
        drive(base, [0.0, 0.1, 0.0], 1.5)  # to the left
        drive(base, [0.0, 0.0, 0.0], 0.5)  # stop
        time.sleep(0.3)
        moved = truth.pose() - start
        s = base.get_state()
    # ahead, then left, without turning (how far depends on how fast the world runs on a loaded machine)
    assert 0.08 < moved[0] < 0.25 and 0.05 < moved[1] < 0.2 and abs(moved[2]) < 0.05, moved
    # the wheel angles the driver read over the bus (encoder steps, unwrapped), through LeKiwi's kinematics:
    # where the base went in the world (it did not turn, so the body frame stayed the world's)
    kin = OmniKinematics.from_degrees(G.PUSH_ANGLES_DEG, G.WHEEL_RADIUS, G.BASE_RADIUS)
    by_wheels = kin.to_body(np.asarray(s["wheel_pos"]) - wheels0)
    assert np.allclose(by_wheels, moved, atol=0.01), (by_wheels, moved)
    assert np.abs(s["wheel_vel"]).max() < 0.05  # stopped: the wheels stand still
    # the kind's odometry integrates the wheel speeds over the wall clock, as on the real base; a world that
    # runs slower than the wall clock (rtf < 1 on a loaded machine) makes it overshoot, never point elsewhere
    odom = np.asarray(s["odom_pose"]) - odom0
    assert float(odom[:2] @ moved[:2]) / (np.linalg.norm(odom[:2]) * np.linalg.norm(moved[:2])) > 0.98, (odom, moved)
