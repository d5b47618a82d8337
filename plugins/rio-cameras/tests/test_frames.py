"""The shared pieces on plain arrays: intrinsics scaled with a resized picture, metric depth to uint16,
the pinhole guess, and the test pattern's colours (BGR out of the capture, RGB after the driver)."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from rio_cameras.fit import fit_frame, scale_intrinsics
from rio_cameras.frames import Frame, metric_to_u16
from rio_cameras.intrinsics import pinhole
from rio_cameras.opencv.capture import CaptureSource, fourcc_text, to_rgb
from rio_cameras.opencv.pattern import BARS_RGB, PatternCapture


def test_intrinsics_follow_pixel_centres_when_scaled():
    k = np.array([[100.0, 0, 63.5], [0, 100.0, 47.5], [0, 0, 1]])  # centre of a 128x96 image
    half = scale_intrinsics(k, 0.5, 0.5)
    np.testing.assert_allclose(half, [[50, 0, 31.5], [0, 50, 23.5], [0, 0, 1]])  # still the centre of 64x48


def test_fit_resizes_depth_without_inventing_distances():
    depth = np.zeros((4, 4), np.uint16)
    depth[:, 2:] = 1000
    f = fit_frame(Frame(rgb=np.zeros((4, 4, 3), np.uint8), t=0.0, depth=depth, intrinsics=np.eye(3)), 8, 8)
    assert f.rgb.shape == (8, 8, 3) and set(np.unique(f.depth)) == {0, 1000}


def test_metric_depth_to_uint16():
    d = np.array([[1.0, np.nan, np.inf, -1.0, 100.0]], np.float32)
    np.testing.assert_array_equal(metric_to_u16(d, unit_m=1.0), [[1000, 0, 0, 0, 65535]])
    np.testing.assert_array_equal(metric_to_u16(np.array([1500.4]), unit_m=0.001), [1500])


def test_pinhole_guess_and_calibration():
    k, source = pinhole(640, 480, hfov_deg=60)
    assert k[0, 0] == pytest.approx(320 / math.tan(math.radians(30))) and k[0, 0] == k[1, 1]
    assert (k[0, 2], k[1, 2]) == (319.5, 239.5) and source.startswith("GUESS")
    k, source = pinhole(640, 480, fx=500, cx=300)
    assert (k[0, 0], k[1, 1], k[0, 2], k[1, 2]) == (500, 500, 300, 239.5) and source.startswith("calibration")


def test_pattern_is_bgr_out_of_the_capture_and_rgb_after_it():
    cap = PatternCapture(80, 40, 30)
    ok, bgr = cap.read()
    assert ok and bgr.shape == (40, 80, 3)
    rgb = to_rgb(bgr)
    assert [tuple(rgb[2, 5 + 10 * i]) for i in range(8)] == list(BARS_RGB)
    frame = CaptureSource(cap).grab()
    assert not np.array_equal(frame.rgb, rgb)  # the square moved
    cap.release()
    assert CaptureSource(cap).grab() is None


def test_to_rgb_handles_grey_and_bgra_and_fourcc_text():
    assert to_rgb(np.full((2, 2), 7, np.uint8)).shape == (2, 2, 3)
    bgra = np.zeros((2, 2, 4), np.uint8)
    bgra[..., 0] = 9
    assert tuple(to_rgb(bgra)[0, 0]) == (0, 0, 9)
    assert fourcc_text(cv2.VideoWriter_fourcc(*"MJPG")) == "MJPG" and fourcc_text(0) == ""
