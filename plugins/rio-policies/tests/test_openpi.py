"""Wire compatibility with openpi's policy server protocol, against a local websocket server that
speaks it. The server decodes with plain msgpack (no helper shared with the adapter) and checks the
exact frame structure openpi-client produces: bytes keys, numpy dtype strings, shapes as arrays."""

from __future__ import annotations

import threading

import msgpack
import numpy as np
import pytest
from rio_policies import openpi_wire
from rio_policies.inputs import state_value
from rio_policies.openpi import OpenPIPolicy
from websockets.sync.server import serve

from rio.policy import ObsLayout
from rio.schema import Camera, SingleArmObs
from rio.station import parse_station
from rio.workflows.deploy import run_deploy


def np_frame(a: np.ndarray) -> dict:
    return {b"__ndarray__": True, b"data": a.tobytes(), b"dtype": a.dtype.str, b"shape": list(a.shape)}


def from_frame(d: dict) -> np.ndarray:
    assert set(d) == {b"__ndarray__", b"data", b"dtype", b"shape"}, d.keys()
    return np.frombuffer(d[b"data"], dtype=np.dtype(d[b"dtype"])).reshape(d[b"shape"])


class OpenPIServer:
    """Metadata frame first; then one reply per observation: actions = state + step index."""

    def __init__(self, horizon: int = 10, fail: bool = False):
        self.horizon, self.fail, self.seen = horizon, fail, []
        self.server = serve(self.handle, "127.0.0.1", 0, compression=None, max_size=None)
        self.port = self.server.socket.getsockname()[1]
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)

    def handle(self, ws) -> None:
        ws.send(msgpack.packb({"policy": "pi05_test", "action_horizon": self.horizon}))
        for message in ws:
            obs = msgpack.unpackb(message)  # raw: no object hook
            self.seen.append(obs)
            if self.fail:
                ws.send("Traceback (most recent call last):\n  ValueError: bad observation")
                continue
            state = from_frame(obs["observation/state"])
            actions = state[None, :] + np.arange(self.horizon, dtype=np.float64)[:, None]
            ws.send(msgpack.packb({"actions": np_frame(actions), "server_timing": {"infer_ms": 1.0}}))

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.server.shutdown()
        self.thread.join(5)


def observation() -> SingleArmObs:
    rgb = np.arange(48 * 64 * 3, dtype=np.uint32).astype(np.uint8).reshape(48, 64, 3)
    return SingleArmObs(proprio=np.array([0.1, 0.2, 0.3, 0.04]), proprio_joints=np.array([0.1, 0.2, 0.3]),
                        gripper_width=0.04, cameras={"front": Camera(rgb=rgb, meta={"timestamp": 1.0})})


def test_adapter_speaks_openpi_frames():
    obs = observation()
    with OpenPIServer() as srv:
        pol = OpenPIPolicy(port=srv.port, image_size=[24, 24], rate_hz=15,
                           images={"observation/exterior_image_1_left": "front"})
        pol.load(ObsLayout.of(obs))
        assert pol.server_metadata == {"policy": "pi05_test", "action_horizon": 10}
        chunk = pol(obs, "pick up the cube", t_obs=5.0, seq=3)
        pol.close()
    sent = srv.seen[0]
    assert sent["prompt"] == "pick up the cube"
    img = from_frame(sent["observation/exterior_image_1_left"])
    assert img.dtype == np.uint8 and img.shape == (24, 24, 3)  # letterboxed: 64x48 -> 24x18 + padding
    assert (img[:3] == 0).all() and (img[-3:] == 0).all() and img[3:21].any()
    np.testing.assert_array_equal(from_frame(sent["observation/state"]), obs.proprio)
    np.testing.assert_allclose(chunk.actions, obs.proprio + np.arange(10)[:, None])
    assert chunk.t_obs == 5.0 and chunk.seq == 3 and chunk.dt == pytest.approx(1 / 15)


def test_server_error_text_frame_is_raised():
    obs = observation()
    with OpenPIServer(fail=True) as srv:
        pol = OpenPIPolicy(port=srv.port)
        pol.load(ObsLayout.of(obs))
        with pytest.raises(RuntimeError, match="bad observation"):
            pol(obs, None, 0.0)
        pol.close()


def test_codec_round_trip_and_refusals():
    msg = {"a": np.arange(6, dtype=np.float32).reshape(2, 3), "b": np.int64(7), "c": [1, "x"]}
    back = openpi_wire.unpackb(openpi_wire.packb(msg))
    np.testing.assert_array_equal(back["a"], msg["a"])
    assert back["b"] == 7 and back["b"].dtype == np.int64 and back["c"] == [1, "x"]
    with pytest.raises(ValueError):
        openpi_wire.packb({"x": np.array([object()])})
    evil = msgpack.packb({b"__ndarray__": True, b"data": b"", b"dtype": "|O", b"shape": [0]})
    with pytest.raises(ValueError):
        openpi_wire.unpackb(evil)


def test_rio_deploy_with_an_openpi_server():
    st = parse_station({"name": "openpitest", "rate_hz": 50, "middleware": {"name": "thread"},
                        "components": {"arm": {"driver": "rio.fake_arm", "dof": 3},
                                       "front_camera": {"driver": "rio.fake_camera", "width": 32, "height": 24}}})
    with OpenPIServer(horizon=20) as srv:
        summary = run_deploy(st, f"openpi.remote,port={srv.port},rate_hz=50", instruction="wave", duration=0.6,
                             log=None)
    assert summary.reason == "duration reached"
    assert summary.details["stats"]["chunks"] >= 2 and srv.seen[0]["prompt"] == "wave"
    assert from_frame(srv.seen[0]["observation/front_image"]).shape == (24, 32, 3)


def test_a_state_map_naming_the_gripper_by_its_old_field_still_reads_it():
    """A station or command line written before Core v3 maps `gripper_position`: it reads `gripper_width`
    (with one notice, `rio.schema.RENAMED_FIELDS`); a field the observation lacks stays an error naming it."""
    obs = observation()
    for ref in ("gripper_width", "gripper_position"):
        np.testing.assert_array_equal(state_value(obs, ref), [0.04])
    with pytest.raises(ValueError, match="has no 'gripper_opening'"):
        state_value(obs, "gripper_opening")
