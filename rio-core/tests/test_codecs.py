"""Camera frames across a network link (`rio.middleware.protocol.codecs`): compressed once by the node's
server, decoded once by each client, other fields (timestamps) untouched, nothing trusted on decode."""

from __future__ import annotations

import numpy as np
import pytest

from rio import ServerManager, connect, serve
from rio.errors import ConfigError
from rio.fakes.sensors import FakeCamera
from rio.middleware.protocol import messages as m
from rio.middleware.protocol.codecs import CODED_HEAD, ENTRY, RecordDecoder, RecordEncoder, encoder_for, resolve
from rio.runtime.layout import Layout
from rio.testing import wait_until

pytest.importorskip("cv2")
pytest.importorskip("zstandard")

H, W = 480, 640


def _scene(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A camera-like colour frame (smooth gradients, edges, mild noise) and a depth frame (a slanted floor
    with a box on it, and holes), as a real RGB-D camera gives them."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:H, 0:W]
    rgb = np.stack([x * 255 // W, y * 255 // H, (x + y) * 255 // (W + H)], -1).astype(np.int16)
    rgb[150:300, 200:400] = (200, 40, 40)
    rgb += rng.integers(-3, 4, rgb.shape, dtype=np.int16)
    depth = (800 + y * 3).astype(np.uint16)
    depth[150:300, 200:400] = 650
    depth[rng.random((H, W)) < 0.02] = 0  # no return
    return np.clip(rgb, 0, 255).astype(np.uint8), depth


def _layout() -> Layout:
    return Layout({"rgb": np.zeros((H, W, 3), np.uint8), "intrinsics": np.eye(3),
                   "depth": np.zeros((H, W), np.uint16), "depth_scale": 0.001}, owner="cam")


def _record(layout: Layout, t: float = 1234.5678) -> np.ndarray:
    rgb, depth = _scene()
    k = np.array([[615.1, 0, 320.2], [0, 615.3, 240.7], [0, 0, 1]])
    return layout.encode({"rgb": rgb, "intrinsics": k, "depth": depth, "depth_scale": 0.00025, "timestamp": t})


def _psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    return float("inf") if mse == 0 else 10 * np.log10(255.0 ** 2 / mse)


@pytest.mark.parametrize("depth_codec", ["zstd", "png"])
def test_jpeg_colour_and_lossless_depth_round_trip_with_the_other_fields_exact(depth_codec):
    layout = _layout()
    rec = _record(layout)
    enc = RecordEncoder("cam", layout, {"rgb": ("jpeg", 90), "depth": (depth_codec, 0)})
    body = enc.encode(rec)
    assert len(body) < layout.itemsize / 4, f"{len(body)} bytes for a {layout.itemsize}-byte record"
    dec = RecordDecoder(layout)
    back = np.frombuffer(bytes(dec.decode(body)), dtype=layout.dtype, count=1)[0]
    np.testing.assert_array_equal(back["depth"], rec["depth"])  # lossless
    assert back["timestamp"] == rec["timestamp"] == 1234.5678  # capture time unchanged, bit for bit
    np.testing.assert_array_equal(back["intrinsics"], rec["intrinsics"])
    assert back["depth_scale"] == rec["depth_scale"]
    assert _psnr(back["rgb"], rec["rgb"]) > 35.0
    # colour channels stay in place (JPEG is BGR to OpenCV): the red box is still red
    assert tuple(np.median(back["rgb"][200:250, 250:350].reshape(-1, 3), axis=0)) == pytest.approx((200, 40, 40), abs=6)
    assert enc.stats.frames == dec.stats.frames == 1 and enc.stats.ratio > 4


def test_jpeg_quality_trades_size_for_fidelity():
    layout = _layout()
    rec = _record(layout)
    sizes, psnrs = [], []
    for q in (30, 95):
        body = RecordEncoder("cam", layout, {"rgb": ("jpeg", q)}).encode(rec)
        back = np.frombuffer(bytes(RecordDecoder(layout).decode(body)), dtype=layout.dtype, count=1)[0]
        np.testing.assert_array_equal(back["depth"], rec["depth"])  # not coded: raw in the rest
        sizes.append(len(body))
        psnrs.append(_psnr(back["rgb"], rec["rgb"]))
    assert sizes[0] < sizes[1] and psnrs[0] < psnrs[1]


def test_auto_is_raw_on_loopback_and_compresses_across_machines_and_a_wrong_codec_names_the_field():
    layout = _layout()
    auto = {"rgb": {"codec": "auto", "quality": 80}, "depth": {"codec": "auto"}}
    assert resolve("cam", layout, auto, linked=False) == {}
    assert resolve("cam", layout, auto, linked=True) == {"rgb": ("jpeg", 80), "depth": ("zstd", 90)}
    assert resolve("cam", layout, {"rgb": {"codec": "raw"}}, linked=True) == {}
    with pytest.raises(ConfigError, match="'cam'.*'depth'.*cannot be JPEG"):
        resolve("cam", layout, {"depth": {"codec": "jpeg"}}, linked=True)
    with pytest.raises(ConfigError, match="'cam'.*'rgb'.*unknown codec 'webp'"):
        resolve("cam", layout, {"rgb": {"codec": "webp"}}, linked=True)
    cam = FakeCamera(depth=True, width=W, height=H)
    cam.name = "cam"
    cam.setup()
    assert encoder_for(cam, Layout(cam.example_data, owner="cam"), linked=False) is None
    assert encoder_for(cam, Layout(cam.example_data, owner="cam"), linked=True) is not None


def test_a_malformed_body_is_refused_not_trusted():
    layout = _layout()
    good = RecordEncoder("cam", layout, {"rgb": ("jpeg", 90), "depth": ("zstd", 0)}).encode(_record(layout))
    dec = RecordDecoder(layout)
    with pytest.raises(ValueError, match="says"):
        dec.decode(good[:-1])
    # a depth frame claiming the colour field (another shape): decoded, then refused
    n, entries = CODED_HEAD.unpack_from(good)[1], bytearray(good)
    first = CODED_HEAD.size
    index, codec, length = ENTRY.unpack_from(good, first)
    ENTRY.pack_into(entries, first, index, 3, length)  # jpeg bytes labelled zstd
    with pytest.raises(ValueError, match="rgb.*zstd"):
        dec.decode(bytes(entries))
    assert n == 2
    dec.decode(good)  # and the decoder still works


def test_a_camera_over_zmq_arrives_decoded_with_its_timestamps(tmp_path):
    """A camera serving jpeg + zstd over zmq (asked for explicitly: on loopback auto would stay raw): the
    client's mirror holds decoded frames of the right shape, exact depth, increasing capture times."""
    opts = {"name": "cam", "rate_hz": 30, "depth": True, "width": 160, "height": 120, "codec": "jpeg",
            "depth_codec": "zstd"}
    with ServerManager("zmq", [serve(FakeCamera, **opts)]):
        with connect(FakeCamera, "zmq", **opts) as cam:
            t = cam._transport  # type: ignore[attr-defined]
            assert wait_until(lambda: t.decoder is not None and t.decoder.stats.frames >= 5, timeout=10)
            s = cam.get_state(k=3)
            assert s["rgb"].shape == (3, 120, 160, 3) and s["depth"].shape == (3, 120, 160)
            assert (s["depth"] == 1000).all()
            assert np.all(np.diff(s["timestamp"]) > 0)
            for frame in s["rgb"]:  # every pixel is one value (the frame counter): JPEG keeps it flat
                assert int(frame.max()) - int(frame.min()) <= 2
            assert t.decoder.stats.coded_bytes < t.decoder.stats.raw_bytes / 10
    assert m.CODED == b"Z"
