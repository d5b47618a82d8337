"""Camera frames reach the policy node by reference where the middleware shares rings (thread, shm) and
inside the request elsewhere (zmq, or `frames="copy"`). Either way the policy sees exactly the frames
the observation was made of, bit for bit; a frame the camera overwrote before the policy node read it
is answered with an empty chunk and counted, never replaced by another frame."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from rio import clock
from rio.errors import ConfigError
from rio.policy import AsyncInference, ObsLayout, PolicyMetadata
from rio.policy.testing import FrameEchoPolicyNode, frame_signature
from rio.runtime.buffers import RingBuffer
from rio.runtime.layout import Layout
from rio.runtime.manager import ServerManager, connect, serve
from rio.runtime.ring_ref import SharedRing
from rio.station import make_station, parse_station


def _station(mw: str, camera_hz: float) -> Any:
    cams = {"front_camera": {"driver": "rio.fake_camera", "width": 32, "height": 24, "rate_hz": camera_hz},
            "wrist_camera": {"driver": "rio.fake_camera", "width": 16, "height": 12, "depth": True,
                             "rate_hz": camera_hz}}
    return parse_station({"name": f"frames-{mw}", "rate_hz": 50, "middleware": {"name": mw},
                          "components": {"arm": {"driver": "rio.fake_arm", "dof": 6, "rate_hz": 100.0}, **cams}})


@contextlib.contextmanager
def _running(mw: str, frames: str = "auto", camera_hz: float = 30.0, forward_s: float = 0.0,
             ) -> Iterator[tuple[Any, Any, dict]]:
    """The station's env, a connected FrameEcho policy node client and the policy's config, as `rio deploy`
    starts them: the layout from the first observation, the policy over the station's middleware."""
    st = _station(mw, camera_hz)
    servers, clients, env = make_station(st)
    mwo = next(iter(clients.values())).mw
    with ServerManager(servers, station=st.name), env:
        kw = {"observation": ObsLayout.of(env.get_state().observation).to_dict(), "frames": frames,
              "forward_s": forward_s}
        with ServerManager([serve(FrameEchoPolicyNode, mwo, name="policy", **kw)], station=st.name), \
                connect(FrameEchoPolicyNode, mwo, name="policy", **kw) as policy:
            yield env, policy, kw


def _answer(policy: Any, seq: int, timeout: float = 15.0) -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        chunk = policy.latest_chunk()
        if chunk is not None and chunk.seq == seq:
            return chunk
        policy.check_alive()
        time.sleep(0.002)
    raise AssertionError(f"no answer to request {seq} within {timeout} s")


def _wait_for_newer_frames(env: Any, step: Any, timeout: float = 10.0) -> None:
    seen = {name: cam.meta["timestamp"] for name, cam in step.observation.cameras.items()}
    deadline = time.monotonic() + timeout
    while any(cam.meta["timestamp"] == seen[name] for name, cam in env.get_state().observation.cameras.items()):
        assert time.monotonic() < deadline, "the cameras published nothing new"
        time.sleep(0.005)


def _assert_saw(chunk: Any, step: Any) -> None:
    for i, (name, cam) in enumerate(step.observation.cameras.items()):
        np.testing.assert_array_equal(chunk.actions[i, :5], frame_signature(cam), err_msg=name)


@pytest.mark.parametrize(("mw", "frames", "by_reference"), [
    ("thread", "auto", True), ("shm", "auto", True), ("shm", "copy", False), ("zmq", "auto", False)])
def test_the_policy_sees_exactly_the_frames_of_each_observation(mw, frames, by_reference):
    with _running(mw, frames) as (env, policy, kw):
        request_fields = set(FrameEchoPolicyNode(**kw).example_request)
        assert ("rgb.front" not in request_fields) == by_reference
        assert ("depth.wrist" not in request_fields) == by_reference
        seq = 0
        for _ in range(2):
            older = env.get_state()
            _wait_for_newer_frames(env, older)
            newer = env.get_state()
            for step in (older, newer, older):  # the last: older frames than the request before
                seq += 1
                policy.request(step.observation, None, step.meta["t_obs"], seq)
                chunk = _answer(policy, seq)
                assert chunk.horizon == 2
                _assert_saw(chunk, step)


@pytest.mark.parametrize("mw", ["thread", "shm"])
def test_a_frame_overwritten_before_the_policy_node_reads_it_is_a_counted_miss(mw):
    with _running(mw, camera_hz=100.0) as (env, policy, _kw):
        stale = env.get_state()
        front = stale.observation.cameras["front"]
        ring = SharedRing(front.meta["source"])
        try:  # wait until the camera has overwritten that frame (its ring keeps 63)
            deadline = time.monotonic() + 20.0
            while ring.ring_buffer.find(front.meta["timestamp"]) is not None:
                assert time.monotonic() < deadline, "the camera never overwrote its frame"
                time.sleep(0.02)
        finally:
            ring.close()
        inf = AsyncInference(policy, PolicyMetadata.from_dict(policy.metadata()))
        inf.request(stale.observation, None, stale.meta["t_obs"], clock.now())
        _answer(policy, inf.seq)
        assert inf.poll(clock.now()) is None  # an empty answer: nothing scheduled, no other frame used
        assert inf.stats()["frame_misses"] == 1 and inf.chunks == 0
        assert inf.in_flight is None and inf.wants_request(clock.now())  # asks again at once
        fresh = env.get_state()
        inf.request(fresh.observation, None, fresh.meta["t_obs"], clock.now())
        _answer(policy, inf.seq)
        chunk = inf.poll(clock.now())
        assert chunk is not None and inf.chunks == 1
        _assert_saw(chunk, fresh)


def test_ring_find_returns_only_a_checked_sample():
    ring = RingBuffer(Layout({"rgb": np.zeros((4, 4, 3), np.uint8)}, owner="cam"), capacity=4)
    assert ring.find(0.0) is None  # nothing published yet
    for i in range(6):
        ring.put({"rgb": np.full((4, 4, 3), i, np.uint8), "timestamp": float(i)})
    for i in (3, 4, 5):  # a ring of 4 keeps the newest 3
        s = ring.find(float(i))
        assert s is not None and s["timestamp"] == float(i) and (s["rgb"] == i).all()
    assert ring.find(2.0) is None  # overwritten
    assert ring.find(3.5) is None and ring.find(9.0) is None  # never published
    ring._slots.raw[4 % 4, 0] ^= 0xFF  # sample 4's bytes changed under its check (a writer mid-copy)
    assert ring.find(4.0) is None


@pytest.mark.slow
def test_a_frame_overwritten_during_the_forward_pass_is_a_counted_miss():
    """The policy reads the frames in place: a camera that comes round to their slot before the forward pass
    ends (a 64-frame ring at 100 Hz, a 3 s forward pass) may have changed the pixels it saw, so the chunk is
    dropped and counted, as if the frame had been gone from the start."""
    with _running("shm", camera_hz=100.0, forward_s=3.0) as (env, policy, _kw):
        inf = AsyncInference(policy, PolicyMetadata.from_dict(policy.metadata()))
        step = env.get_state()
        inf.request(step.observation, None, step.meta["t_obs"], clock.now())
        _answer(policy, inf.seq, timeout=30.0)
        assert inf.poll(clock.now()) is None and inf.stats()["frame_misses"] == 1 and inf.chunks == 0


@pytest.mark.parametrize("stores_in_order", [True, False], ids=["x86", "reordering-cpu"])
def test_ring_find_view_is_the_sample_in_place_until_its_slot_comes_round(monkeypatch, stores_in_order):
    from rio.runtime import slot_check

    monkeypatch.setattr(slot_check, "STORES_IN_ORDER", stores_in_order)
    ring = RingBuffer(Layout({"rgb": np.zeros((4, 4, 3), np.uint8)}, owner="cam"), capacity=4)
    for i in range(3):
        ring.put({"rgb": np.full((4, 4, 3), i, np.uint8), "timestamp": float(i)})
    found = ring.find_view(1.0)
    assert found is not None
    view, seq = found
    assert seq == 1 and (view["rgb"] == 1).all() and not view["rgb"].flags.writeable
    assert ring.holds(seq)
    ring.put({"rgb": np.full((4, 4, 3), 3, np.uint8), "timestamp": 3.0})
    assert ring.holds(seq) and (view["rgb"] == 1).all()
    ring.put({"rgb": np.full((4, 4, 3), 4, np.uint8), "timestamp": 4.0})  # the next sample, 5, goes to slot 1:
    assert not ring.holds(seq) and (view["rgb"] == 1).all()  # a writer may be at it now
    ring.put({"rgb": np.full((4, 4, 3), 5, np.uint8), "timestamp": 5.0})
    assert not ring.holds(seq) and (view["rgb"] == 5).all()  # what `holds` is there to catch
    assert ring.find_view(1.0) is None
    if stores_in_order:  # the check's sequence number is what says the slot is complete
        ring._slots.checks[4 % 4, 0] = 0
    else:  # sample 4's bytes changed under its check (or not yet visible here)
        ring._slots.raw[4 % 4, 0] ^= 0xFF
    assert ring.find_view(4.0) is None


def test_a_ring_that_cannot_be_read_in_place_is_a_config_error():
    ref = {"middleware": "rio.middleware.thread:ThreadMiddleware", "station": "elsewhere", "node": "cam",
           "address": {"station": "elsewhere", "node": "cam"}, "capacity": 4,
           "sample": {"rgb": ["|u1", [2, 2, 3]], "timestamp": ["<f8", []]}}
    with pytest.raises(ConfigError, match="cannot be read in place"):
        SharedRing(ref)
    with pytest.raises(ConfigError, match="another machine"):
        SharedRing({**ref, "address": {**ref["address"], "machine": "some-other-machine"}})
