"""Wire compatibility with Isaac-GR00T's ZMQ inference service (N1.5 flat and N1.6 nested
observations), against a local REP server that decodes frames with plain msgpack + np.load."""

from __future__ import annotations

import io
import threading

import msgpack
import numpy as np
import pytest
import zmq
from rio_policies.gr00t import Gr00tPolicy

from rio.policy import ObsLayout
from rio.schema import Camera, SingleArmObs


def npy(a: np.ndarray) -> dict:
    buf = io.BytesIO()
    np.save(buf, a, allow_pickle=False)
    return {"__ndarray_class__": True, "as_npy": buf.getvalue()}


def decode(obj):
    if isinstance(obj, dict) and obj.get("__ndarray_class__"):
        return np.load(io.BytesIO(obj["as_npy"]), allow_pickle=False)
    return obj


class Gr00tServer:
    """Answers ping, get_action (N1.5 dict or N1.6 [actions, info]) and reset like the real service."""

    def __init__(self, protocol: str, horizon: int = 16):
        self.protocol, self.horizon, self.requests = protocol, horizon, []
        self.ctx = zmq.Context()
        self.sock = self.ctx.socket(zmq.REP)
        self.port = self.sock.bind_to_random_port("tcp://127.0.0.1")
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)

    def run(self) -> None:
        poller = zmq.Poller()
        poller.register(self.sock, zmq.POLLIN)
        while not self.stop.is_set():
            if not poller.poll(50):
                continue
            req = msgpack.unpackb(self.sock.recv(), object_hook=decode)
            self.requests.append(req)
            ep = req.get("endpoint", "get_action")
            if ep == "ping":
                reply = {"status": "ok", "message": "Server is running"}
            elif ep == "reset":
                reply = {}
            elif ep == "get_action" and self.protocol == "n1.5":
                arm = req["data"]["state.arm"][0]
                steps = np.arange(self.horizon)[:, None]
                reply = {"action.arm": npy(arm[None, :] + steps), "action.gripper": npy(np.ones((self.horizon, 1)))}
            elif ep == "get_action":
                arm = req["data"]["observation"]["state"]["arm"][0, 0].astype(np.float64)
                steps = np.arange(self.horizon)[:, None]
                reply = [{"arm": npy((arm[None, :] + steps)[None]), "gripper": npy(np.ones((1, self.horizon, 1)))}, {}]
            else:
                reply = {"error": f"Unknown endpoint: {ep}"}
            self.sock.send(msgpack.packb(reply))

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join(5)
        self.sock.close(linger=0)
        self.ctx.term()


def observation() -> SingleArmObs:
    return SingleArmObs(proprio=np.array([0.1, 0.2, 0.3, 0.04]),
                        cameras={"head": Camera(rgb=np.full((24, 32, 3), 9, np.uint8), meta={"timestamp": 1.0})})


CONFIG = dict(video={"ego_view": "head"}, state={"arm": "proprio[0:3]", "gripper": "proprio[3:]"},
              action_keys=["arm", "gripper"], rate_hz=30)


@pytest.mark.parametrize("protocol", ["n1.5", "n1.6"])
def test_adapter_speaks_gr00t_service(protocol):
    obs = observation()
    with Gr00tServer(protocol) as srv:
        pol = Gr00tPolicy(port=srv.port, protocol=protocol, **CONFIG)
        pol.load(ObsLayout.of(obs))
        pol.reset()
        chunk = pol(obs, "pick the box", t_obs=2.0, seq=1)
        pol.close()
    assert srv.requests[0] == {"endpoint": "ping"}
    req = srv.requests[-1]
    assert req["endpoint"] == "get_action"
    if protocol == "n1.5":
        data = req["data"]
        assert data["video.ego_view"].shape == (1, 24, 32, 3) and data["video.ego_view"].dtype == np.uint8
        np.testing.assert_array_equal(data["state.arm"], [[0.1, 0.2, 0.3]])
        assert data["annotation.human.task_description"] == ["pick the box"]
    else:
        assert srv.requests[1] == {"endpoint": "reset", "data": {"options": None}}
        o = req["data"]["observation"]
        assert req["data"]["options"] is None
        assert o["video"]["ego_view"].shape == (1, 1, 24, 32, 3)
        assert o["state"]["gripper"].shape == (1, 1, 1) and o["state"]["gripper"].dtype == np.float32
        assert o["language"]["annotation.human.task_description"] == [["pick the box"]]
    want = np.concatenate([obs.proprio[:3] + np.arange(16)[:, None], np.ones((16, 1))], axis=1)
    np.testing.assert_allclose(chunk.actions, want, rtol=1e-6)
    assert chunk.dt == pytest.approx(1 / 30)


def test_server_error_and_timeout():
    obs = observation()
    with Gr00tServer("n1.5") as srv:
        pol = Gr00tPolicy(port=srv.port, **{**CONFIG, "action_keys": ["legs"]})
        pol.load(ObsLayout.of(obs))
        with pytest.raises(RuntimeError, match="legs"):
            pol(obs, None, 0.0)
        pol.close()
    ctx = zmq.Context()
    silent = ctx.socket(zmq.REP)
    port = silent.bind_to_random_port("tcp://127.0.0.1")
    pol = Gr00tPolicy(port=port, timeout_ms=100, **CONFIG)
    with pytest.raises(TimeoutError, match="did not answer 'ping'"):
        pol.load(ObsLayout.of(obs))
    pol.close()
    silent.close(linger=0)
    ctx.term()
