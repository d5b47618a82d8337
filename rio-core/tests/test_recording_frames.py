"""Camera frames on their way into a recording: copied once, from the camera node's ring straight into the
encoder's ring (the observation never copies them out), stored exactly as a frame copied out first was;
a frame overwritten during that copy is dropped and counted, never stored torn; and a recording's encoder
check asks for the depth encoder only when depth is recorded."""

from __future__ import annotations

import numpy as np
import pytest

from rio.recording import Dataset, Recorder, RecordingError
from rio.recording.recorder import env_depth
from rio.recording.synthetic import SyntheticCamera, synthetic_step
from rio.recording.video import StreamWriter, VideoOptions, read_frames, video_problem
from rio.runtime.buffers import RingBuffer
from rio.runtime.layout import Layout
from rio.schema import Camera, RingCamera, depth_meters

av = pytest.importorskip("av")

H, W = 24, 32


def camera_ring(depth_scale: float | None, capacity: int = 8) -> RingBuffer:
    """A camera node's ring buffer, as `rio.interfaces.camera` lays out its samples."""
    example: dict = {"rgb": np.zeros((H, W, 3), np.uint8), "intrinsics": np.eye(3)}
    if depth_scale is not None:
        example.update(depth=np.zeros((H, W), np.uint16), depth_scale=depth_scale)
    return RingBuffer(Layout(example, owner="front_camera"), capacity)


def publish(ring: RingBuffer, i: float, scene: SyntheticCamera, rng: np.random.Generator,
            depth_scale: float = 0.001) -> float:
    """Publish frame `i`, stamped 1000 + i/30 s (a moving scene; depth: random integers over the whole
    uint16 range); its timestamp."""
    ts = 1000.0 + i / 30
    sample: dict = {"rgb": scene.frame(i / 30), "intrinsics": np.eye(3), "timestamp": ts}
    if "depth" in ring.layout.names:
        sample.update(depth=rng.integers(0, 65536, (H, W), dtype=np.uint16), depth_scale=depth_scale)
    ring.put(sample)
    return ts


def step_with(i: int, cam: Camera):
    step = synthetic_step(i, float(cam.meta["timestamp"]))
    step.observation.cameras = {"front": cam}
    return step


@pytest.mark.parametrize("scale", [0.001, 0.00025])
def test_frames_go_from_the_camera_ring_into_the_encoder_and_are_stored_as_when_copied_out(tmp_path, scale):
    """One recorder takes each frame from the ring in place (`RingCamera`, as `Env` hands it out), the
    other the same frame copied out first (`Camera.from_sample`, depth in meters: the former path). The
    observation's own copy is never made, and both episodes decode to the same rgb and depth integers;
    depth in the camera's own unit (1 mm) is stored as the very integers the camera published."""
    ring, scene, rng = camera_ring(scale), SyntheticCamera(H, W, noise=1.0), np.random.default_rng(1)
    cams: list[RingCamera] = []
    published = []
    with Recorder(tmp_path / "ring", fps=30, camera_fps=30, video={"crf": 18}) as direct, \
            Recorder(tmp_path / "copy", fps=30, camera_fps=30, video={"crf": 18}) as copied:
        for i in range(12):
            ts = publish(ring, i, scene, rng, scale)
            published.append(ring.find(ts))
            cam = RingCamera(ring, "front_camera", {"timestamp": ts})
            direct.add(step_with(i, cam))
            cams.append(cam)
            copied.add(step_with(i, Camera.from_sample(ring.find(ts))))
        a, b = direct.keep(), copied.keep()
    assert not any(c.taken for c in cams)  # nothing was copied out of the ring for the recorder
    assert a["streams"]["front.depth"]["frames"] == b["streams"]["front.depth"]["frames"] == 12
    ea, eb = Dataset(tmp_path / "ring").episode(0), Dataset(tmp_path / "copy").episode(0)
    depth_a, depth_b = list(ea.frames("front", "depth")), list(eb.frames("front", "depth"))
    for got, want in zip(depth_a, depth_b, strict=True):
        np.testing.assert_array_equal(got, want)
    if scale == 0.001:
        for got, sample in zip(depth_a, published, strict=True):
            np.testing.assert_array_equal(got, sample["depth"])
    rgb_a, rgb_b = list(ea.frames("front")), list(eb.frames("front"))
    assert len(rgb_a) == len(rgb_b) == 12
    for got, want, sample in zip(rgb_a, rgb_b, published, strict=True):
        np.testing.assert_array_equal(got, want)  # same pixels into the same encoder settings
        assert np.abs(got.astype(int) - sample["rgb"].astype(int)).mean() < 10  # H.264 CRF 18, tiny frame


@pytest.mark.parametrize("scale", [0.001, 0.0001, 0.00025, float(np.float32(0.001))])
def test_depth_in_camera_units_is_encoded_as_the_same_depth_in_meters(tmp_path, scale):
    """Every uint16 value, written in the camera's units (the encoder converts) and in meters (as a
    Camera carries it), decodes to the same stored integers."""
    units = np.arange(65536, dtype=np.uint16).reshape(256, 256)
    out = {}
    for form in ("units", "meters"):
        w = StreamWriter(tmp_path / f"{form}.mkv", "depth", 256, 256, 30, VideoOptions())
        w.write(units, scale) if form == "units" else w.write(depth_meters(units, scale))
        w.close()
        out[form] = next(read_frames(tmp_path / f"{form}.mkv", "depth"))
    np.testing.assert_array_equal(out["units"], out["meters"])
    if np.float32(scale) == np.float32(0.001):
        np.testing.assert_array_equal(out["units"], units)


class LappedRing:
    """The camera ring, with its camera writing a ring's worth of new frames (the real writer, the real
    slots) right after the recorder found its frame and before it finished copying it: the overwrite
    a recorder far behind its camera meets. Only the timing is staged; the slot check is the real one."""

    def __init__(self, ring: RingBuffer, scene: SyntheticCamera, rng: np.random.Generator):
        self.ring, self.scene, self.rng, self.lap = ring, scene, rng, False
        self.written: list[np.ndarray] = []  # depth of the frames the lap wrote

    def __getattr__(self, name: str):
        return getattr(self.ring, name)

    def find_view(self, timestamp: float):
        found = self.ring.find_view(timestamp)
        if self.lap:  # stamped between this frame and the next
            i, n = (timestamp - 1000.0) * 30, self.ring.capacity
            for k in range(n):
                ts = publish(self.ring, i + (k + 1) / (n + 1), self.scene, self.rng)
                self.written.append(self.ring.find(ts)["depth"])
        return found


def test_a_frame_overwritten_while_it_is_copied_is_dropped_not_stored(tmp_path):
    ring, scene, rng = camera_ring(0.001), SyntheticCamera(H, W, noise=0.0), np.random.default_rng(2)
    lapped = LappedRing(ring, scene, rng)
    with Recorder(tmp_path / "ds", fps=30, camera_fps=30) as rec:
        for i in range(6):
            ts = publish(ring, i, scene, rng)
            lapped.lap = i == 3
            frame = ring.find(ts)
            rec.add(step_with(i, RingCamera(lapped, "front_camera", {"timestamp": ts})))
            if i != 3:
                last = frame
        meta = rec.keep()
    info = meta["streams"]["front.rgb"]
    assert info["frames"] == 5 and info["dropped"] == 1 and meta["streams"]["front.depth"]["dropped"] == 1
    assert any("gone from its camera's ring" in w for w in meta["warnings"])
    ep = Dataset(tmp_path / "ds").episode(0)
    assert list(ep.step_frame_index("front")) == [0, 1, 2, 2, 3, 4]  # step 3 shows the frame before
    depth = list(ep.frames("front", "depth"))
    np.testing.assert_array_equal(depth[-1], last["depth"])  # the frames after it are the right ones
    assert not any(np.array_equal(d, w) for d in depth for w in lapped.written)  # nothing of the lap stored


def test_rgb_only_recording_does_not_need_the_depth_encoder(tmp_path, monkeypatch):
    """A PyAV whose FFmpeg lacks FFV1 records a station of colour cameras; one with depth is refused at
    open, naming the encoder. Whether depth is recorded comes from the env's connected cameras."""
    real = av.codec.Codec

    def no_ffv1(name, mode="r"):
        if name == "ffv1":
            raise ValueError("no ffv1 in this build")
        return real(name, mode)

    monkeypatch.setattr(av.codec, "Codec", no_ffv1)
    assert video_problem(VideoOptions(), depth=False) is None
    assert "'ffv1'" in video_problem(VideoOptions(), depth=True)
    with Recorder(tmp_path / "rgb", fps=30, cameras=True, depth=False) as rec:
        assert rec.encoder is not None
    with pytest.raises(RecordingError, match="no 'ffv1' encoder"):
        Recorder(tmp_path / "depth", fps=30, cameras=True, depth=True).open()

    class Client:  # a connected camera client: what env_depth reads is its ring's sample layout
        def __init__(self, scale):
            self.ring_buffer = camera_ring(scale, capacity=2)

    class Env:
        rate_hz, station = 30.0, "cams"

        def __init__(self, *scales):
            self.camera_clients = dict.fromkeys(map(str, scales), None)
            self.cameras = {str(s): Client(s) for s in scales}

    assert env_depth(Env(None)) is False and env_depth(Env(None, 0.001)) is True
    assert env_depth(type("Unconnected", (), {"camera_clients": {"front": None}, "cameras": {}})()) is True
    with Recorder(tmp_path / "env-rgb", env=Env(None)) as rec:
        assert rec.cameras and not rec.depth
    with pytest.raises(RecordingError, match="no 'ffv1' encoder"):
        Recorder(tmp_path / "env-depth", env=Env(None, 0.001)).open()


def test_a_plain_camera_between_ring_frames_keeps_its_stream(tmp_path):
    """A stream started from ring frames (depth as the camera's integers) that then gets a frame whose
    pixels were already taken (depth in meters) stores it in the same units, exactly."""
    ring, scene, rng = camera_ring(0.001), SyntheticCamera(H, W), np.random.default_rng(3)
    sent = []
    with Recorder(tmp_path / "ds", fps=30, camera_fps=30) as rec:
        for i in range(5):
            ts = publish(ring, i, scene, rng)
            cam = RingCamera(ring, "front_camera", {"timestamp": ts})
            if i % 2:
                _ = cam.depth  # taken: the recorder gets the observation's copy, depth in meters
            sent.append(ring.find(ts)["depth"])
            rec.add(step_with(i, cam))
        rec.keep()
    for got, want in zip(Dataset(tmp_path / "ds").episode(0).frames("front", "depth"), sent, strict=True):
        np.testing.assert_array_equal(got, want)


def _logged(rr, path) -> dict[str, dict[str, list]]:
    """{entity: {column: values}} of an .rrd, read back with rerun's own reader."""
    out: dict[str, dict[str, list]] = {}
    for chunk in rr.chunk.RrdReader(path).stream():
        b = chunk.to_record_batch()
        cols = out.setdefault(chunk.entity_path, {})
        for name in b.schema.names:
            if name.startswith(("Image:", "DepthImage:")):
                cols.setdefault(name, []).extend(b.column(b.schema.get_field_index(name)).to_pylist())
    return out


def test_the_live_viewer_logs_frames_read_in_place(tmp_path):
    """`rio teleop --viz` logs a step's camera frame from the camera ring itself (nothing copied out
    first: the one copy is rerun's), depth as the camera's integers with their scale; a frame gone from
    the ring is skipped, not an error and not another frame."""
    rr = pytest.importorskip("rerun")
    from rio.viz import RerunViz

    ring, scene, rng = camera_ring(0.00025), SyntheticCamera(H, W), np.random.default_rng(4)
    ts = publish(ring, 0, scene, rng, 0.00025)
    sample = ring.find(ts)
    cam = RingCamera(ring, "front_camera", {"timestamp": ts})
    gone = RingCamera(ring, "front_camera", {"timestamp": 999.0})  # not in the ring (overwritten long ago)
    viz = RerunViz(rr, "live", str(tmp_path / "live.rrd"))
    viz.time(0.0, 0)
    viz.camera("cameras/front", cam)
    viz.camera("cameras/side", gone)
    viz.close()
    assert not cam.taken
    logged = _logged(rr, tmp_path / "live.rrd")
    assert not any(e.startswith("/cameras/side") for e in logged)
    rgb, depth = logged["/cameras/front/rgb"], logged["/cameras/front/depth"]
    assert np.array_equal(np.array(rgb["Image:buffer"][0][0], np.uint8), sample["rgb"].ravel())
    assert np.array_equal(np.array(depth["DepthImage:buffer"][0][0], np.uint8).view(np.uint16), sample["depth"].ravel())
    assert depth["DepthImage:meter"][0] == [pytest.approx(4000.0)]


def test_the_lens_distortion_is_recorded_beside_the_intrinsics(tmp_path):
    """A camera that publishes its distortion has it stored with its stream's intrinsics; one that does not
    is stored as a pinhole camera ("none", zeros); an episode written before the field existed still reads."""
    import json

    from rio.interfaces.camera import distortion_fields

    example = {"rgb": np.zeros((H, W, 3), np.uint8), "intrinsics": np.eye(3), **distortion_fields("none")}
    ring = RingBuffer(Layout(example, owner="front_camera"), 4)
    coeffs = [0.1, -0.2, 0.003, 0.004, 0.05]
    with Recorder(tmp_path / "ds", fps=30, camera_fps=30) as rec:
        for i in range(3):
            ring.put({"rgb": SyntheticCamera(H, W).frame(i), "intrinsics": 2 * np.eye(3), "timestamp": 1000.0 + i,
                      **distortion_fields("kannala_brandt4", coeffs[:4])})
            step = step_with(i, RingCamera(ring, "front_camera", ring_meta(ring)))
            step.observation.cameras["wrist"] = Camera(rgb=np.zeros((H, W, 3), np.uint8),
                                                      meta={"timestamp": 1000.0 + i, "intrinsics": np.eye(3)})
            rec.add(step)
        meta = rec.keep()
    front, wrist = meta["streams"]["front.rgb"], meta["streams"]["wrist.rgb"]
    assert front["distortion_model"] == "kannala_brandt4" and front["distortion"] == [*coeffs[:4], 0.0]
    assert front["intrinsics"] == (2 * np.eye(3)).tolist()
    assert wrist["distortion_model"] == "none" and wrist["distortion"] == [0.0] * 5
    path = tmp_path / "ds" / meta["dir"] / "episode.json"
    old = json.loads(path.read_text())
    for info in old["streams"].values():
        info.pop("distortion_model", None), info.pop("distortion", None)
    path.write_text(json.dumps(old))
    ep = Dataset(tmp_path / "ds").episode(0)
    assert ep.verify() == [] and len(list(ep.frames("front"))) == 3 and "distortion" not in ep.streams["front.rgb"]


def ring_meta(ring: RingBuffer) -> dict:
    from rio.schema import camera_meta

    return camera_meta(ring.get(copy=False))
