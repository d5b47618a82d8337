"""`cameras.uvc`'s own logic (device selection, mode negotiation and its report, unplug -> reopen) against
`FakeVideoCapture`: a fake of cv2.VideoCapture over a V4L2 webcam. There is no /dev/video here and no
v4l2loopback, so the V4L2 protocol itself is not exercised: the fake answers `get()` with whatever its
"driver" granted, as V4L2 does after picking the nearest mode it supports. The real OpenCV capture path
is covered by test_stream.py (a real file through cv2.VideoCapture) and test_hardware.py (a real webcam)."""

from __future__ import annotations

import contextlib
import logging
import math
import time

import cv2
import numpy as np
import pytest
from pydantic import ValidationError
from rio_cameras.errors import CameraError
from rio_cameras.opencv import capture
from rio_cameras.uvc.driver import UvcCamera

from rio.conformance.drivers import CameraConformance
from rio.testing import lifecycle, wait_until

_PROPS = {cv2.CAP_PROP_FRAME_WIDTH: "width", cv2.CAP_PROP_FRAME_HEIGHT: "height", cv2.CAP_PROP_FPS: "fps",
          cv2.CAP_PROP_FOURCC: "fourcc"}


class Webcam:
    """The hardware behind the fake: what its driver grants (None: whatever is asked), whether it is
    plugged in, and every open and set() it saw."""

    def __init__(self, grant: dict | None = None, plugged: bool = True):
        self.grant, self.plugged = grant or {}, plugged
        self.opened_with: list = []
        self.sets: list = []


class FakeVideoCapture:
    """A fake of cv2.VideoCapture (see the module docstring). Frames: left half red, right half blue (RGB),
    handed out in OpenCV's BGR order at the granted size, one per 1/fps seconds like a live camera."""

    def __init__(self, cam: Webcam, target, api):
        self.cam, self.props = cam, {}
        self.opened = cam.plugged
        cam.opened_with.append((target, api))

    def isOpened(self):  # noqa: N802 - cv2's spelling
        return self.opened

    def getBackendName(self):  # noqa: N802
        return "V4L2 (fake)"

    def set(self, prop, value):
        self.cam.sets.append((prop, value))
        self.props[prop] = value
        return True

    def get(self, prop):
        name = _PROPS.get(prop)
        if name in self.cam.grant:
            v = self.cam.grant[name]
            return float(cv2.VideoWriter_fourcc(*v)) if name == "fourcc" else float(v)
        return float(self.props.get(prop, 0.0))

    def read(self):
        if not (self.opened and self.cam.plugged):
            return False, None
        time.sleep(1 / 60)
        w, h = int(self.get(cv2.CAP_PROP_FRAME_WIDTH)), int(self.get(cv2.CAP_PROP_FRAME_HEIGHT))
        img = np.zeros((h, w, 3), np.uint8)
        img[:, : w // 2] = (0, 0, 255)  # BGR red
        img[:, w // 2:] = (255, 0, 0)  # BGR blue
        return True, img

    def release(self):
        self.opened = False


@contextlib.contextmanager
def fake_webcam(cam: Webcam):
    """Make the driver's capture factory hand out FakeVideoCaptures of `cam`."""
    original = capture.open_video_capture
    capture.open_video_capture = lambda target, api, params=(): FakeVideoCapture(cam, target, api)
    try:
        yield cam
    finally:
        capture.open_video_capture = original


@pytest.fixture
def webcam():
    with fake_webcam(Webcam()) as cam:
        yield cam


def next_sample(node, timeout: float = 10.0) -> dict:
    seen: list = []
    assert wait_until(lambda: seen.append(node.read_state()) or seen[-1] is not None, timeout=timeout)
    return seen[-1]


class TestUvcConformance(CameraConformance):
    """The camera kit on cameras.uvc over the fake capture (the driver's code, not V4L2's)."""

    driver = "cameras.uvc"
    config = {"device": 0, "width": 64, "height": 48}
    bad_config = {"device": "/dev/rio-no-such-video"}

    @contextlib.contextmanager
    def emulator(self):
        with fake_webcam(Webcam()):
            yield None


def test_mode_is_requested_format_first_with_a_one_frame_buffer(webcam):
    with lifecycle(UvcCamera(device=0, width=64, height=48, rate_hz=30)) as node:
        s = next_sample(node)
        info = node.camera_info()
    assert webcam.opened_with == [(0, cv2.CAP_V4L2)]
    order = [p for p, _ in webcam.sets]
    assert order[:5] == [cv2.CAP_PROP_FOURCC, cv2.CAP_PROP_FRAME_WIDTH, cv2.CAP_PROP_FRAME_HEIGHT, cv2.CAP_PROP_FPS,
                         cv2.CAP_PROP_BUFFERSIZE]
    assert dict(webcam.sets)[cv2.CAP_PROP_BUFFERSIZE] == 1
    assert dict(webcam.sets)[cv2.CAP_PROP_FOURCC] == cv2.VideoWriter_fourcc(*"MJPG")
    assert info["requested"] == info["negotiated"] == "64x48@30 MJPG" and info["differences"] == []
    assert s["rgb"].shape == (48, 64, 3)
    assert tuple(s["rgb"][10, 5]) == (255, 0, 0) and tuple(s["rgb"][10, 60]) == (0, 0, 255)  # BGR -> RGB


def test_a_mode_the_camera_did_not_grant_is_reported_and_resized(caplog):
    cam = Webcam(grant={"width": 64, "height": 48, "fps": 15, "fourcc": "YUYV"})
    with fake_webcam(cam), caplog.at_level(logging.INFO, logger="rio_cameras"):
        with lifecycle(UvcCamera(device=0, width=160, height=90, rate_hz=30)) as node:
            s = next_sample(node)
            info = node.camera_info()
    report = "requested 160x90@30 MJPG, got 64x48@15 YUYV"
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert any(report in w and "resized to 160x90" in w and "stretched" in w for w in warnings), warnings
    assert info["negotiated"] == "64x48@15 YUYV"
    assert info["differences"] == ["width 160 -> 64", "height 90 -> 48", "fps 30 -> 15", "format MJPG -> YUYV"]
    assert s["rgb"].shape == (90, 160, 3)


def test_strict_refuses_a_mode_the_camera_did_not_grant():
    cam = Webcam(grant={"width": 64, "height": 48})
    with fake_webcam(cam), pytest.raises(CameraError, match=r"strict = true.*requested 160x90@30 MJPG, got 64x48@30"):
        with lifecycle(UvcCamera(device=0, width=160, height=90, strict=True)):
            pass


def test_a_driver_without_a_frame_rate_is_not_a_mismatch(caplog):
    cam = Webcam(grant={"fps": 0})
    with fake_webcam(cam), lifecycle(UvcCamera(device=0, width=64, height=48, strict=True)) as node:
        info = node.camera_info()
    assert info["differences"] == [] and info["negotiated"] == "64x48@? MJPG"


def test_unplug_is_a_named_error_the_node_survives_and_replug_reopens(webcam, caplog):
    with caplog.at_level(logging.INFO, logger="rio_cameras"), \
            lifecycle(UvcCamera(device=0, width=64, height=48, reopen_s=0.1)) as node:
        node.name = "wrist"
        next_sample(node)
        webcam.plugged = False
        assert wait_until(lambda: "reopen failed" in (node.camera_info()["error"] or ""), timeout=10)
        info = node.camera_info()
        assert info["lost"] == 1 and not info["connected"]
        assert "lost" in info["error"] and "could not open it" in info["error"]
        node.read_state()  # a frame grabbed just before the unplug, if any
        frames = node.camera_info()["frames"]
        assert node.read_state() is None and node.camera_info()["frames"] == frames  # nothing new while gone
        webcam.plugged = True
        assert wait_until(lambda: node.camera_info()["reopened"] == 1, timeout=10)
        s = next_sample(node)
        info = node.camera_info()
    assert s["rgb"].shape == (48, 64, 3) and info["error"] is None and info["connected"]
    errors = [r.getMessage() for r in caplog.records if r.levelno == logging.ERROR]
    assert any("cameras.uvc" in e and "lost" in e and "stays up" in e for e in errors), errors


def test_by_id_paths_are_resolved_and_missing_paths_named(webcam, tmp_path):
    dev = tmp_path / "video3"
    dev.write_text("")
    link = tmp_path / "by-id" / "usb-Acme_Cam_0001-video-index0"
    link.parent.mkdir()
    link.symlink_to(dev)
    with lifecycle(UvcCamera(device=str(link), width=64, height=48)) as node:
        assert f"{link} -> {dev}" in node.camera_info()["device"]
    assert webcam.opened_with == [(str(dev), cv2.CAP_V4L2)]
    with pytest.raises(CameraError, match="does not exist.*rio cameras list"):
        with lifecycle(UvcCamera(device=str(tmp_path / "by-id" / "gone"))):
            pass


def test_an_index_with_no_camera_is_named():
    with fake_webcam(Webcam(plugged=False)), pytest.raises(CameraError, match="index 3.*no camera at that index"):
        with lifecycle(UvcCamera(device="3")):
            pass


def test_controls_are_set_and_read_back(webcam):
    with lifecycle(UvcCamera(device=0, width=64, height=48, controls={"autofocus": 0, "focus": 20})) as node:
        info = node.camera_info()
    assert (cv2.CAP_PROP_FOCUS, 20.0) in webcam.sets
    assert info["controls"]["focus"] == {"requested": 20.0, "read_back": 20.0}
    with pytest.raises(ValidationError, match="unknown capture control 'focsu'"):
        UvcCamera(controls={"focsu": 1})


def test_intrinsics_are_a_labelled_guess_unless_configured(webcam):
    guess = UvcCamera(width=640, height=480, hfov_deg=90)
    assert guess.k[0, 0] == pytest.approx(320 / math.tan(math.radians(45)))
    assert guess.camera_info()["intrinsics"].startswith("GUESS from hfov_deg = 90")
    calibrated = UvcCamera(width=640, height=480, fx=600, fy=601, cx=322, cy=241)
    np.testing.assert_allclose(calibrated.k, [[600, 0, 322], [0, 601, 241], [0, 0, 1]])
    assert calibrated.camera_info()["intrinsics"].startswith("calibration")


def test_a_calibrated_lens_distortion_is_published_with_every_frame(webcam):
    """A webcam calibrated with OpenCV (its K and [k1, k2, p1, p2, k3] in the station file) publishes the
    distortion beside the intrinsics; an uncalibrated one publishes none (a pinhole camera); a bad model
    or too many coefficients is a config error naming the field."""
    from rio.schema import DISTORTION_MODELS

    coeffs = [-0.28, 0.07, 0.001, -0.0005, 0.0]
    with lifecycle(UvcCamera(device=0, width=64, height=48, fx=60, distortion_model="brown_conrady",
                             distortion=coeffs)) as node:
        s = next_sample(node)
    assert DISTORTION_MODELS[int(s["distortion_model"])] == "brown_conrady"
    np.testing.assert_array_equal(s["distortion"], coeffs)
    with lifecycle(UvcCamera(device=0, width=64, height=48)) as node:
        assert "distortion" not in next_sample(node)
    with pytest.raises(ValidationError, match="unknown distortion model 'plumb'"):
        UvcCamera(distortion_model="plumb")
    with pytest.raises(ValidationError, match="at most 5 finite coefficients"):
        UvcCamera(distortion_model="brown_conrady", distortion=[0.1] * 8)
    with pytest.raises(ValidationError, match="name their model"):
        UvcCamera(distortion=[0.1])
