"""Frames injected through pyrealsense2's own software device (sensors, profiles, extrinsics, syncer,
`rs.align`) come out of the driver as the camera contract's state with the right values: the scene
(`rio_realsense.scene`) is known exactly, so each published frame is compared with the frame the
scene renders for its frame number."""

from __future__ import annotations

import time

import numpy as np
import pytest
from rio_realsense.doctor import LIBUSB

from rio import clock
from rio.testing import lifecycle, skip_tests_without

skip_tests_without(LIBUSB)  # first: without libusb, importing pyrealsense2 raises ImportError (not a skip)
pytest.importorskip("pyrealsense2")

from rio_realsense import scene  # noqa: E402
from rio_realsense.driver import RealSenseCamera  # noqa: E402
from rio_realsense.errors import RealSenseError  # noqa: E402
from rio_realsense.sources.software import MODELS  # noqa: E402


def software(serial: str, **fields) -> RealSenseCamera:
    return RealSenseCamera(source="software", serial=serial, **{"width": 128, "height": 96, **fields})


def scene_time(sample) -> float:
    return int(sample["frame_number"]) / 30.0


def test_colour_intrinsics_and_metric_depth(serial, collect):
    cam = software(serial, depth=True)
    with lifecycle(cam):
        samples = collect(cam, 5)
    model = MODELS["d400"]
    color_cam = scene.Pinhole.from_hfov(128, 96, model.color_hfov)
    for s in samples:
        assert s["rgb"].shape == (96, 128, 3) and s["rgb"].dtype == np.uint8
        assert s["depth"].shape == (96, 128) and s["depth"].dtype == np.uint16
        # the gradient, pixel for pixel (red grows to the right, green downward), the plate white
        assert np.array_equal(s["rgb"], scene.color(color_cam, scene_time(s), cam_x=model.baseline_m))
        assert s["rgb"][0, 0].tolist() == [0, 0, 64] and s["rgb"][95, 127].tolist() == [255, 255, 64]
        np.testing.assert_allclose(s["intrinsics"], color_cam.matrix(), rtol=1e-5)
        # metric depth through the scale the depth sensor reports: the wall at 1 m, the plate at 0.8 m
        assert s["depth_scale"] == pytest.approx(0.001, rel=1e-6)
        metres = s["depth"] * s["depth_scale"]
        assert set(np.unique(np.round(metres, 3))) <= {0.8, 1.0}
        assert np.mean(np.isclose(metres, 0.8, atol=0.002)) > 0.02  # the plate is in view


def test_the_scale_is_read_from_the_depth_sensor_not_assumed(collect):
    """The L515 preset's software camera counts depth in quarter millimetres."""
    cam = RealSenseCamera(source="software", serial="l515-scale", product_line="l500", width=96, height=54, depth=True)
    with lifecycle(cam):
        s = collect(cam, 2)[-1]
    assert s["depth_scale"] == pytest.approx(0.00025, rel=1e-6)
    assert np.median(s["depth"]) == 4000  # the wall, 1 m
    assert cam.model == "Intel RealSense L515"


def test_depth_is_aligned_to_colour(serial, collect):
    """Depth at half the colour resolution and a wider field of view (87 vs 69 degrees), 15 mm to the
    side: after `rs.align` the plate in depth covers the same colour pixels as the white plate in rgb,
    and the depth equals what the scene renders from the colour camera, but at the plate's edges."""
    cam = software(serial, depth=True, depth_width=64, depth_height=48)
    with lifecycle(cam):
        samples = collect(cam, 4)
    model = MODELS["d400"]
    color_cam = scene.Pinhole.from_hfov(128, 96, model.color_hfov)
    depth_cam = scene.Pinhole.from_hfov(64, 48, model.depth_hfov)
    assert depth_cam.fx / depth_cam.width != pytest.approx(color_cam.fx / color_cam.width, rel=0.1)
    for s in samples:
        t = scene_time(s)
        expected = scene.depth_m(color_cam, t, cam_x=model.baseline_m)
        got = s["depth"] * s["depth_scale"]
        assert np.mean(s["depth"] > 0) > 0.98  # the wider depth view covers the colour view
        plate = scene.plate_mask(color_cam, t, cam_x=model.baseline_m)
        near_edge = _grow(plate, 2) & ~_shrink(plate, 2)
        wrong = (np.abs(got - expected) > 0.005) & (s["depth"] > 0)
        assert not np.any(wrong & ~near_edge), np.argwhere(wrong & ~near_edge)[:5]
        # the plate in depth covers the rgb's white plate, give or take 2 pixels at its edges
        white = np.all(s["rgb"] == 255, axis=2)
        assert np.array_equal(white, plate)
        near = np.isclose(got, 0.8, atol=0.005)
        assert np.all(near[_shrink(plate, 2)]) and not np.any(near & ~_grow(plate, 2))
        # unaligned (depth resized to colour) it would be 72 % as wide: not what we got
        assert near.sum() > 0.9 * white.sum()


def _grow(mask: np.ndarray, r: int) -> np.ndarray:
    out = mask.copy()
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            out |= np.roll(np.roll(mask, dy, axis=0), dx, axis=1)
    return out


def _shrink(mask: np.ndarray, r: int) -> np.ndarray:
    return ~_grow(~mask, r)


def test_frames_are_new_each_time_and_stamped_before_they_arrive(serial, collect):
    cam = software(serial, depth=True)
    taken = []
    with lifecycle(cam):
        take = cam.grabber.take

        def recording_take():
            got = take()
            if got is not None:
                taken.append(got[0])
            return got

        cam.grabber.take = recording_take
        samples = []
        for s in collect(cam, 12):
            samples.append(s)
            t_read = clock.now()
            assert s["t_frame"] <= t_read and s["frame_age"] >= 0.0
            assert s["timestamp"] == s["t_frame"]
    numbers = [int(s["frame_number"]) for s in samples]
    assert np.all(np.diff(numbers) > 0), numbers  # never the same frame twice
    stamps = [s["t_frame"] for s in samples]
    assert np.all(np.diff(stamps) > 0)
    for frame in taken:
        assert frame.t_frame <= frame.t_arrival
        assert frame.t_arrival - frame.t_frame < 2.0  # sane: the offset was learned, not a clock base apart


def test_never_publishes_a_frame_twice(serial):
    cam = software(serial, rate_hz=15)
    with lifecycle(cam):
        seen = []
        t_end = clock.now() + 1.5
        while clock.now() < t_end:
            s = cam.read_state()  # far faster than the camera: most calls find nothing new
            if s is not None:
                seen.append(int(s["frame_number"]))
            time.sleep(0.001)
        assert len(seen) >= 2 and len(seen) == len(set(seen))


def test_colour_only(serial, collect):
    cam = software(serial)
    keys = {"rgb", "intrinsics", "distortion_model", "distortion", "frame_number", "t_frame", "frame_age", "timestamp"}
    assert set(cam.example_data) == keys
    with lifecycle(cam):
        s = collect(cam, 2)[-1]
    assert set(s) == keys


def test_the_colour_lens_distortion_comes_from_the_sdk(serial, collect, monkeypatch):
    """The colour stream's distortion model and coefficients, as the SDK's intrinsics report them (here
    set on the software camera's profile), are published with every frame and reach `Camera.meta`."""
    import dataclasses

    from rio.schema import DISTORTION_MODELS, Camera

    coeffs = (0.12, -0.25, 0.001, -0.002, 0.08)
    monkeypatch.setitem(MODELS, "d400", dataclasses.replace(MODELS["d400"], color_distortion=("brown_conrady", coeffs)))
    cam = software(serial, depth=True)
    with lifecycle(cam):
        s = collect(cam, 2)[-1]
    assert DISTORTION_MODELS[int(s["distortion_model"])] == "brown_conrady"
    np.testing.assert_allclose(s["distortion"], coeffs, rtol=1e-6)  # the SDK keeps them as float32
    meta = Camera.from_sample({**s, "timestamp": s["timestamp"]}).meta
    assert meta["distortion_model"] == "brown_conrady" and np.allclose(meta["distortion"], coeffs, rtol=1e-6)


def test_settings_reach_the_sensor_options(serial):
    """Exposure in microseconds becomes the RGB sensor's 100 us units; white balance, emitter and sync
    mode are written to the options the software camera registers like a D435's."""
    import pyrealsense2 as rs

    cam = software(serial, depth=True, exposure=10000, white_balance=4000, emitter=False, hardware_sync="master")
    with lifecycle(cam):
        dev = cam.stream.source.device()
        color, depth = (next(s for s in dev.query_sensors() if s.get_info(rs.camera_info.name) == n)
                        for n in ("RGB Camera", "Stereo Module"))
        assert color.get_option(rs.option.enable_auto_exposure) == 0
        assert color.get_option(rs.option.exposure) == 100
        assert color.get_option(rs.option.enable_auto_white_balance) == 0
        assert color.get_option(rs.option.white_balance) == 4000
        assert depth.get_option(rs.option.emitter_enabled) == 0
        assert depth.get_option(rs.option.inter_cam_sync_mode) == 1
        assert cam.camera_info()["settings"] == {"global_time": True, "exposure": 10000.0, "white_balance": 4000.0,
                                                 "emitter": False, "hardware_sync": "master"}


def test_hardware_sync_on_a_camera_without_it_is_an_error():
    cam = RealSenseCamera(source="software", serial="l515-sync", product_line="l500", width=96, height=54,
                          hardware_sync="slave")
    with pytest.raises(RealSenseError, match="RealSense l515-sync: hardware_sync"):
        with lifecycle(cam):
            pass
