"""Three emulated RealSense cameras (software devices: the SDK's own frames, alignment and timestamps)
recorded by the real loop and recorder, exported to LeRobot v3: every exported video frame matches the
frame the loop saw at that step, within the codec's tolerance."""

from __future__ import annotations

import numpy as np
import pytest
from rio_realsense.doctor import LIBUSB

from rio.testing import fake_eef_station, skip_tests_without

skip_tests_without(LIBUSB)  # first: without libusb, importing pyrealsense2 raises ImportError (not a skip)
pytest.importorskip("pyrealsense2")
av = pytest.importorskip("av")

STATION = fake_eef_station("three-realsense", 'driver = "teleop.scripted"', gripper=False, rate_hz=15)
CAMERAS = ("wrist", "front", "side")


def _decode(path) -> list[np.ndarray]:
    with av.open(str(path)) as c:
        return [f.to_ndarray(format="rgb24") for f in c.decode(video=0)]


def test_three_cameras_record_and_export_to_lerobot_with_their_frames(tmp_path, serial):
    pytest.importorskip("rio_datasets")
    from rio.recording import Dataset, Recorder
    from rio.recording.format import get_format
    from rio.workflows.teleop import run_teleop

    text = STATION + "".join(
        f'[components.{cam}_camera]\ndriver = "realsense.d400"\nsource = "software"\nserial = "{serial}-{cam}"\n'
        f"width = 160\nheight = 120\nrate_hz = 30\ndepth = {'true' if cam == 'front' else 'false'}\n"
        for cam in CAMERAS)
    path = tmp_path / "three-realsense.toml"
    path.write_text(text)
    seen: dict[str, list[np.ndarray]] = {cam: [] for cam in CAMERAS}
    root = tmp_path / "data"
    with Recorder(root, fps=15, station="three-realsense", cameras=True) as rec:
        def on_step(tick) -> None:
            rec.add(tick.step)
            for cam in CAMERAS:
                seen[cam].append(tick.step.observation.cameras[cam].rgb.copy())

        run_teleop(str(path), "scripted", duration=2.0, middleware="thread", on_tick=on_step, log=None)
        rec.keep()
    ep = Dataset(root).episode(0)
    assert set(ep.cameras) >= set(CAMERAS) and len(ep) == len(seen["wrist"]) > 10
    for key in ("front.rgb", "front.depth", "side.rgb"):  # the lens as the SDK reported it, beside the intrinsics
        info = ep.streams[key]
        assert info["distortion_model"] == "inverse_brown_conrady" and info["distortion"] == [0.0] * 5, key
        assert np.asarray(info["intrinsics"]).shape == (3, 3)
    out = tmp_path / "lerobot"
    get_format("lerobot", {"codec": "h264"}).export(Dataset(root), out)
    for cam in CAMERAS:
        frames = _decode(out / f"videos/observation.images.{cam}/chunk-000/file-000.mp4")
        assert len(frames) == len(seen[cam]), cam
        for got, want in zip(frames, seen[cam], strict=True):
            assert got.shape == want.shape
            assert np.abs(got.astype(int) - want.astype(int)).mean() < 8.0, cam  # H.264 twice, CRF 28
    # the frames are of a moving scene (a match is not just one still picture)
    assert max(np.abs(f.astype(int) - seen["front"][0].astype(int)).mean() for f in seen["front"]) > 1.0
