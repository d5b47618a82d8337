"""Chunk alignment, blending and late handling, checked numerically (no processes, time passed in)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rio.policy import ActionChunk, AsyncConfig, AsyncInference, ChunkSchedule, PolicyMetadata, ScheduleConfig

DT = 0.02  # 50 Hz actions
V = np.array([0.5, -1.0])  # ramp slope per second


def ramp_chunk(t_obs: float, h: int = 10, seq: int = 1) -> ActionChunk:
    """A chunk sampling the line V * t at its own action times (offset 1)."""
    times = t_obs + (np.arange(h) + 1) * DT
    return ActionChunk(times[:, None] * V[None, :], t_obs, DT, 1.0, seq)


def const_chunk(t_obs: float, value: float, h: int = 10, seq: int = 1) -> ActionChunk:
    return ActionChunk(np.full((h, 2), value), t_obs, DT, 1.0, seq)


@pytest.mark.parametrize("blend", ["latest", "crossfade", "ensemble"])
def test_aligned_ramps_give_the_ramp_whatever_the_latency(blend):
    s = ChunkSchedule(ScheduleConfig(blend=blend, crossfade_s=0.05))
    # chunk 1 from an observation at 1.0 arrives 90 ms later; chunk 2 from 1.09 arrives at 1.18
    assert s.add(ramp_chunk(1.00, seq=1), t_now=1.09) == 4  # times 1.02..1.08 already past: dropped
    for t in np.arange(1.09, 1.18, 0.003):
        np.testing.assert_allclose(s.sample(t).action, V * t, atol=1e-12)
    s.add(ramp_chunk(1.09, seq=2), t_now=1.18)
    for t in np.arange(1.18, 1.28, 0.003):
        smp = s.sample(t)
        np.testing.assert_allclose(smp.action, V * t, atol=1e-12)
        assert smp.seq == 2 and smp.t_obs == 1.09 and not smp.late


def test_unaligned_execution_would_lag_by_the_latency():
    """What alignment fixes: playing a chunk from its first action at arrival lags by the latency."""
    chunk = ramp_chunk(1.0)
    naive_at_arrival = chunk.actions[0]  # what a loop without latency compensation sends at t = 1.09
    s = ChunkSchedule()
    s.add(chunk, t_now=1.09)
    np.testing.assert_allclose(s.sample(1.09).action, V * 1.09)
    np.testing.assert_allclose(V * 1.09 - naive_at_arrival, V * 0.07)


def test_crossfade_is_linear_over_its_window():
    s = ChunkSchedule(ScheduleConfig(blend="crossfade", crossfade_s=0.1))
    s.add(const_chunk(0.9, 0.0, h=30, seq=1), t_now=0.95)
    s.add(const_chunk(0.95, 1.0, h=30, seq=2), t_now=1.0)
    for t, want in [(0.99, 0.0), (1.0, 0.0), (1.025, 0.25), (1.05, 0.5), (1.1, 1.0), (1.2, 1.0)]:
        np.testing.assert_allclose(s.sample(t).action, want, atol=1e-12)
    assert s.sample(1.05).seq == 2  # the newest contributor names the command


def test_latest_switches_at_arrival():
    s = ChunkSchedule(ScheduleConfig(blend="latest"))
    s.add(const_chunk(0.9, 0.0, h=30), t_now=0.95)
    assert s.sample(1.0).action[0] == 0.0
    s.add(const_chunk(0.95, 1.0, h=30, seq=2), t_now=1.0)
    assert s.sample(1.0).action[0] == 1.0
    assert len(s.placed) == 1  # the older chunk can no longer contribute


@pytest.mark.parametrize("decay", [0.0, 0.01, -0.5])
def test_temporal_ensemble_weights(decay):
    s = ChunkSchedule(ScheduleConfig(blend="ensemble", ensemble_decay=decay))
    s.add(const_chunk(0.9, 0.0, h=30), t_now=0.95)
    s.add(const_chunk(0.95, 1.0, h=30, seq=2), t_now=1.0)
    s.add(const_chunk(1.0, 4.0, h=30, seq=3), t_now=1.05)
    w = np.exp(-decay * np.arange(3))
    np.testing.assert_allclose(s.sample(1.06).action, (w @ np.array([0.0, 1.0, 4.0])) / w.sum())
    np.testing.assert_allclose(s.sample(1.02).action, (w[:2] @ np.array([0.0, 1.0])) / w[:2].sum())
    # past the oldest chunk's end (0.9 + 30 * 0.02 = 1.5) only the newer two remain
    np.testing.assert_allclose(s.sample(1.51).action, (w[:2] @ np.array([1.0, 4.0])) / w[:2].sum())


def test_interpolates_between_actions():
    s = ChunkSchedule(ScheduleConfig(blend="latest"))
    s.add(ActionChunk(np.array([[0.0], [1.0], [3.0]]), 0.0, 0.1, 1.0), t_now=0.0)
    for t, want in [(0.1, 0.0), (0.15, 0.5), (0.2, 1.0), (0.25, 2.0), (0.3, 3.0)]:
        assert s.sample(t).action[0] == pytest.approx(want)


def test_late_hold_and_continue():
    hold = ChunkSchedule(ScheduleConfig(blend="latest", on_late="hold"))
    hold.add(ramp_chunk(1.0, h=5), t_now=1.0)  # last action at 1.10
    assert not hold.sample(1.10).late
    late = hold.sample(1.2)
    assert late.late
    np.testing.assert_allclose(late.action, V * 1.10)
    cont = ChunkSchedule(ScheduleConfig(blend="latest", on_late="continue", max_continue_s=0.05))
    cont.add(ramp_chunk(1.0, h=5), t_now=1.0)
    np.testing.assert_allclose(cont.sample(1.13).action, V * 1.13)  # follows the chunk's velocity ...
    np.testing.assert_allclose(cont.sample(1.5).action, V * 1.15)  # ... for at most max_continue_s


class FakeClient:
    """A policy client answering each request with a ramp chunk after `latency` seconds (sim time)."""

    def __init__(self, latency: float, horizon: int = 10):
        self.latency, self.horizon = latency, horizon
        self.now = 0.0
        self.pending: list[tuple[float, ActionChunk]] = []
        self.published: list[ActionChunk] = []

    def request(self, obs, instruction, t_obs, seq, reset=False):
        c = ramp_chunk(t_obs, self.horizon, seq)
        c.t_recv, c.t_start, c.t_end = t_obs, t_obs, t_obs + self.latency
        self.pending.append((t_obs + self.latency, c))

    def advance(self, t):
        self.now = t
        while self.pending and self.pending[0][0] <= t:
            self.published.append(self.pending.pop(0)[1])

    def chunk_count(self):
        return len(self.published) + 1

    def latest_chunk(self):
        return self.published[-1] if self.published else None


def run_loop(latency, threshold, control_hz=100.0, seconds=1.0, horizon=10, on_late="hold"):
    client = FakeClient(latency, horizon)
    meta = PolicyMetadata("fake", 2, horizon, DT)
    inf = AsyncInference(client, meta, AsyncConfig(request_threshold=threshold, blend="crossfade",
                                                   crossfade_s=0.04, on_late=on_late))
    stream = []
    for k in range(int(seconds * control_hz)):
        t = k / control_hz
        client.advance(t)
        inf.poll(t)
        s = inf.command(t + 1 / control_hz)
        if s is not None:
            inf.applied(s, t)
            stream.append((t + 1 / control_hz, s))
        if inf.wants_request(t):
            inf.request(None, None, t, t)
    return inf, stream


def test_async_loop_commands_the_ramp_and_never_starves():
    inf, stream = run_loop(latency=0.085, threshold=1.0)
    assert inf.late_ticks == 0 and inf.late_events == 0
    for t_target, s in stream:
        np.testing.assert_allclose(s.action, V * t_target, atol=1e-12)
    # back-to-back requests: each chunk is first used right when it lands
    assert np.allclose(inf.record.first_action.values(), 0.09)  # 85 ms, seen at the next 10 ms tick
    assert inf.stats()["requests"] >= 10


def test_async_loop_counts_late_events_and_holds():
    # chunks of 10 x 20 ms = 200 ms of actions, requested with 1 action left, arriving 150 ms later
    inf, stream = run_loop(latency=0.15, threshold=0.1)
    assert inf.late_events >= 2 and inf.late_ticks > inf.late_events
    late = [s for _, s in stream if s.late]
    assert late and all(np.allclose(s.action, V * (s.t_obs + 10 * DT)) for s in late)  # held at chunk end


def test_threshold_is_a_fraction_of_the_chunk():
    with pytest.raises(ValueError):
        AsyncConfig(request_threshold=1.5)
    with pytest.raises(ValueError):
        ScheduleConfig(blend="average")
    assert math.isclose(ramp_chunk(0.0).times()[0], DT)
