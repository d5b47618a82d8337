"""`cameras.stream` against the REAL OpenCV: a small MJPG AVI is written with cv2.VideoWriter into a
temporary folder and read back through cv2.VideoCapture (FFMPEG backend) by the driver, so the capture,
decode, BGR->RGB, pacing, looping and resizing are all the shipped code on a real file.

The video: the left half pure red, the right half pure blue (as RGB), and a grey band along the bottom
whose level encodes the frame number (20 * i), so a sample says which frame it is. Regions are 16-pixel
aligned so MJPG's 2x2 chroma subsampling keeps the colours within a few levels."""

from __future__ import annotations

import contextlib
import tempfile
from pathlib import Path

import cv2
import numpy as np
import pytest
from rio_cameras.errors import CameraError
from rio_cameras.stream.driver import StreamCamera
from rio_cameras.stream.url import classify, redact

from rio.conformance.drivers import CameraConformance
from rio.testing import lifecycle, wait_until

RED, BLUE = (255, 0, 0), (0, 0, 255)  # RGB


def write_avi(path: Path, width: int = 64, height: int = 48, frames: int = 6, fps: float = 30.0) -> Path:
    """An MJPG AVI: red | blue halves, the frame number as the bottom band's grey level (20 * i)."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (width, height))
    assert writer.isOpened(), "this OpenCV cannot write MJPG AVI"
    for i in range(frames):
        rgb = np.zeros((height, width, 3), np.uint8)
        rgb[:, : width // 2] = RED
        rgb[:, width // 2:] = BLUE
        rgb[height - 16:] = 20 * i
        writer.write(cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    writer.release()
    return path


def next_sample(cam, timeout: float = 10.0) -> dict:
    """The next sample the node publishes (polling its read_state, as the runtime's loop does)."""
    seen: list = []
    assert wait_until(lambda: seen.append(cam.read_state()) or seen[-1] is not None, timeout=timeout)
    return seen[-1]


def frame_number(rgb: np.ndarray) -> int:
    return int(round(float(np.median(rgb[-8:, :, 1])) / 20))


@pytest.fixture
def avi(tmp_path):
    return write_avi(tmp_path / "six.avi")


class TestStreamConformance(CameraConformance):
    """The camera kit on cameras.stream playing a freshly written AVI through cv2.VideoCapture."""

    driver = "cameras.stream"
    config = {"width": 64, "height": 48}
    bad_config = {"url": "/nonexistent/rio-no-such-video.avi"}

    @contextlib.contextmanager
    def emulator(self):
        with tempfile.TemporaryDirectory() as d:
            yield {"url": str(write_avi(Path(d) / "kit.avi"))}


class TestPatternConformance(CameraConformance):
    """The same kit on url = "test:pattern" (synthetic frames, same path after the capture object)."""

    driver = "cameras.stream"
    config = {"url": "test:pattern", "width": 48, "height": 32}
    bad_config = {"url": "/nonexistent/rio-no-such-video.avi"}


def test_colours_come_out_as_rgb(avi):
    with lifecycle(StreamCamera(url=str(avi), width=64, height=48)) as cam:
        rgb = next_sample(cam)["rgb"]
    assert rgb.shape == (48, 64, 3) and rgb.dtype == np.uint8
    assert np.abs(rgb[8:24, 4:28].astype(int) - RED).max() < 24, rgb[16, 16]
    assert np.abs(rgb[8:24, 36:60].astype(int) - BLUE).max() < 24, rgb[16, 48]


def test_file_loops_and_frames_carry_grab_time_and_age(avi):
    """Six frames at 60 Hz: within a few seconds the frame numbers wrap from 5 back to 0. Every sample's
    timestamp is its grab time (before the publish), frame_age the gap, frame_index increasing."""
    samples: list[dict] = []

    def wrapped() -> bool:
        s = cam.read_state()
        if s is not None:
            samples.append(s)
        numbers = [frame_number(x["rgb"]) for x in samples]
        return any(b < a for a, b in zip(numbers, numbers[1:], strict=False))

    with lifecycle(StreamCamera(url=str(avi), width=64, height=48, rate_hz=60)) as cam:
        assert wait_until(wrapped, timeout=20, period=0.004), [frame_number(x["rgb"]) for x in samples]
        info = cam.camera_info()
    assert set(frame_number(x["rgb"]) for x in samples) <= set(range(6))
    indices = [int(x["frame_index"]) for x in samples]
    assert indices == sorted(set(indices))
    stamps = [float(x["timestamp"]) for x in samples]
    assert stamps == sorted(stamps)
    assert all(0.0 <= float(x["frame_age"]) < 5.0 for x in samples)
    assert info["connected"] and info["error"] is None and info["source"] == "file"
    assert "64x48" in info["delivered"] and "GUESS" in info["intrinsics"]


def test_end_of_file_without_loop_stops_publishing(avi):
    with lifecycle(StreamCamera(url=str(avi), width=64, height=48, rate_hz=60, loop=False)) as cam:
        assert wait_until(lambda: cam.camera_info()["finished"], timeout=10)
        cam.read_state()  # the last frame, if not taken yet
        assert cam.read_state() is None
        assert cam.camera_info()["frames"] == 6


def test_another_size_is_resized_with_its_intrinsics(tmp_path):
    path = write_avi(tmp_path / "big.avi", width=128, height=96)
    with lifecycle(StreamCamera(url=str(path), width=64, height=48, fx=50.0)) as cam:
        s = next_sample(cam)
        assert cam.camera_info()["delivered"].startswith("128x96")
    assert s["rgb"].shape == (48, 64, 3)
    assert np.abs(s["rgb"][16, 16].astype(int) - RED).max() < 24
    # the configured calibration is for the published image: fy defaults to fx, centre to the middle
    np.testing.assert_allclose(s["intrinsics"], [[50, 0, 31.5], [0, 50, 23.5], [0, 0, 1]])


def test_missing_file_and_missing_gstreamer_are_named_errors():
    with pytest.raises(CameraError, match="no such file"):
        with lifecycle(StreamCamera(url="/nonexistent/x.avi")):
            pass
    if not cv2.videoio_registry.hasBackend(cv2.CAP_GSTREAMER):
        with pytest.raises(CameraError, match="no GStreamer support"):
            with lifecycle(StreamCamera(url="videotestsrc ! videoconvert ! appsink")):
                pass


def test_depth_is_refused_for_opencv_sources():
    with pytest.raises(ValueError, match="colour only"):
        StreamCamera(url="test:pattern", depth=True)


def test_urls_are_classified_and_passwords_kept_out_of_messages():
    assert classify("test:pattern") == "pattern"
    assert classify("rtsp://10.0.0.5:554/stream1") == "network"
    assert classify("http://cam.local/mjpg/video.mjpg") == "network"
    assert classify("v4l2src ! videoconvert ! appsink") == "gstreamer"
    assert classify("/data/demo.avi") == "file"
    assert redact("rtsp://admin:s3cret@10.0.0.5/stream") == "rtsp://admin:***@10.0.0.5/stream"
    cam = StreamCamera(url="rtsp://admin:s3cret@10.0.0.5/stream")
    assert "s3cret" not in cam.label and "s3cret" not in str(cam.camera_info())
