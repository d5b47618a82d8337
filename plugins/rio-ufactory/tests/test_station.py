"""The emulator station end to end, through the real command line: the scripted pick-and-place with
`rio teleop xarm7-sim --record` (the rio-ufactory drivers, the unmodified SDK, the emulated
controller backed by rio-sim physics, each node in its own process), then `rio deploy` replaying the
recorded episode on the same station. The world's ground truth says the cube was carried to the pad."""

from __future__ import annotations

import numpy as np
import pytest
from rio_ufactory.loopback import PORT_502_HINT, can_listen_on_502

from rio.recording.dataset import Dataset
from rio.testing import run_rio as rio
from rio.testing import run_scripted_square

pytestmark = pytest.mark.skipif(not can_listen_on_502(), reason=PORT_502_HINT)

STATION = "xarm7-sim"


@pytest.mark.parametrize("station", ["xarm7-emulator", "lite6-emulator"])
def test_emulator_stations_trace_the_scripted_square(station):
    run_scripted_square(station)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    pytest.importorskip("rio_sim")
    pytest.importorskip("mujoco")
    root = tmp_path_factory.mktemp("data") / "pick"
    out = rio("teleop", STATION, "--teleop", "scripted", "--duration", "20", "--record", str(root),
              "--on-end", "keep", "--instruction", "put the red cube on the blue pad")
    assert "1 episode(s) kept" in out.stdout, out.stdout[-2000:]
    assert "the device finished" in out.stdout, out.stdout[-2000:]
    return root, out.stdout


@pytest.mark.slow
def test_scripted_pick_and_place_through_the_sdk_moves_the_cube_to_the_pad_and_records_it(recorded):
    from rio_sim.testing import check_recorded_pick_and_place

    root, _ = recorded
    check_recorded_pick_and_place(root)


@pytest.mark.slow
def test_the_recording_holds_the_emulator_truth(recorded):
    root, _ = recorded
    ep = Dataset(root).episode(0)
    names = ep.columns.dtype.names
    assert "meta.sensors.emulator.joint_pos" in names, names
    truth, measured = ep.column("meta.sensors.emulator.joint_pos"), ep.column("obs.proprio")
    assert truth.shape[1] == 7 and np.isfinite(truth).all()
    assert np.ptp(truth, axis=0).max() > 0.2 and measured.shape[0] == truth.shape[0]  # the arm really moved


@pytest.mark.slow
def test_deploy_replaying_the_episode_does_the_task_again(recorded, tmp_path):
    from rio_sim.testing import cube_path

    root, _ = recorded
    rollout = tmp_path / "rollout"
    rio("deploy", STATION, "--policy", f"replay.episode,episode={root}", "--duration", "20", "--record",
        str(rollout))
    taught, replayed = cube_path(root), cube_path(rollout)
    assert np.linalg.norm(replayed[-1, :2] - replayed[0, :2]) > 0.10
    assert np.linalg.norm(replayed[-1, :2] - taught[-1, :2]) < 0.02  # put down where the teleoperator put it
