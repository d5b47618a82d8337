"""Asynchronous inference, client side: when to ask for the next chunk, taking chunks in as they
arrive, and the command for each control tick. Nothing here waits for the policy.

- Request: at most one observation is in flight. The next is sent as soon as the actions left in the
  newest chunk fall to `request_threshold` x its horizon (1.0: ask again the moment a chunk arrives,
  which keeps the model busy and the actions young; lower values trade action age for compute).
- Arrival: `poll()` compares the policy's ring-buffer count with the last seen (a local read), and
  schedules a new chunk on the `ChunkSchedule` (aligned to its observation's time, blended). An empty
  chunk answers a request whose camera frames were overwritten before the policy node read them
  (`rio.policy.frames`): it is counted (`frame_misses`) and the next observation goes out at once.
- Command: `command(t)` samples the schedule for time `t`, then the optional low-pass filter
  (`rio.control.LowPassFilter`). Before the first chunk, and whenever the policy is late, the caller
  gets the hold (or continued) command and the event is counted.

It also keeps the latency record that `rio deploy` reports and the benchmark prints: for each chunk,
capture-to-first-applied-action time and the forward pass; for each applied action, its age.
"""

from __future__ import annotations

import collections
from dataclasses import dataclass, field
from typing import Any

from rio import clock
from rio.control.filters import LowPassFilter
from rio.control.reservoir import Reservoir
from rio.policy.base import ActionChunk, PolicyMetadata
from rio.policy.schedule import ChunkSchedule, Sample, ScheduleConfig


@dataclass
class AsyncConfig:
    request_threshold: float = 0.5
    blend: str = "crossfade"
    crossfade_s: float = 0.1
    ensemble_decay: float = 0.01
    on_late: str = "hold"
    max_continue_s: float = 0.25
    lowpass_hz: float | None = None
    #: An observation unanswered this long is given up on and sent again (counted).
    request_timeout_s: float = 10.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.request_threshold <= 1.0:
            raise ValueError(f"request_threshold is a fraction of the chunk, in [0, 1]; got {self.request_threshold}")

    def schedule(self) -> ScheduleConfig:
        return ScheduleConfig(self.blend, self.crossfade_s, self.ensemble_decay, self.on_late,  # type: ignore[arg-type]
                              self.max_continue_s)


@dataclass
class LatencyRecord:
    """Times in seconds, `rio.clock.now()` clock; one value per chunk or per applied action, kept in bounded
    reservoirs (`rio.control.reservoir`: a deploy may run for hours at the control rate)."""

    first_action: Reservoir = field(default_factory=Reservoir)
    #: First action minus that chunk's own forward pass: what the framework added.
    overhead: Reservoir = field(default_factory=Reservoir)
    forward: Reservoir = field(default_factory=Reservoir)
    #: Observation time -> request enqueued (main process), and -> taken in by the policy node.
    sent: Reservoir = field(default_factory=Reservoir)
    queue_in: Reservoir = field(default_factory=Reservoir)
    action_age: Reservoir = field(default_factory=Reservoir)
    dropped: Reservoir = field(default_factory=Reservoir)


class AsyncInference:
    """Drives one policy node client (a `PolicyNode` proxy) from a control loop."""

    def __init__(self, policy: Any, meta: PolicyMetadata, config: AsyncConfig | None = None):
        self.policy, self.meta = policy, meta
        self.config = config or AsyncConfig()
        self.schedule = ChunkSchedule(self.config.schedule())
        self.filter = LowPassFilter(self.config.lowpass_hz) if self.config.lowpass_hz else None
        self.seq = 0
        self.in_flight: tuple[int, float] | None = None  # (seq, time sent)
        self._seen = policy.chunk_count()
        self._first_pending: dict[int, float] = {}  # seq -> forward pass of chunks not applied yet
        self.record = LatencyRecord()
        self.requests = self.chunks = self.timeouts = self.frame_misses = 0
        self.late_events = self.late_ticks = 0
        self._late = False
        self._reset_next = True
        #: request -> chunk seen, of the last few chunks: when the next one is due (`expected_arrival`)
        self._round_trips: collections.deque[float] = collections.deque(maxlen=8)

    def restart(self) -> None:
        """A new episode on the same policy node (`rio eval`'s next trial): forget the chunks of the last one
        and what was in flight (its answer, if it still comes, is stale by its `seq`, which keeps counting),
        and reset the policy with the next request. The statistics go on over the episodes."""
        self.schedule = ChunkSchedule(self.config.schedule())
        self.filter = LowPassFilter(self.config.lowpass_hz) if self.config.lowpass_hz else None
        self.in_flight = None
        self._seen = self.policy.chunk_count()
        self._first_pending.clear()
        self._late = False
        self._reset_next = True

    # -- chunks in ----------------------------------------------------------------------------------
    def arrived(self) -> bool:
        """A chunk is waiting to be taken in (one local counter read)."""
        return self.policy.chunk_count() != self._seen

    def poll(self, t_now: float) -> ActionChunk | None:
        """Take in the newest chunk if one arrived (scheduled at `t_now`); stale replies are ignored."""
        count = self.policy.chunk_count()
        if count == self._seen:
            return None
        self._seen = count
        chunk = self.policy.latest_chunk()
        if chunk is None or self.in_flight is None or chunk.seq != self.in_flight[0]:
            return None
        if chunk.horizon == 0:  # not run: a referenced frame was gone; ask again with a fresh observation
            self.frame_misses += 1
            self.in_flight = None
            return None
        self._round_trips.append(clock.now() - self.in_flight[1])
        self.record.queue_in.add(chunk.t_recv - chunk.t_obs)
        self.record.forward.add(chunk.forward_s)
        self.record.dropped.add(self.schedule.add(chunk, t_now))
        self._first_pending[chunk.seq] = chunk.forward_s
        self.in_flight = None
        self.chunks += 1
        return chunk

    def expected_arrival(self) -> float | None:
        """The earliest time the chunk in flight is likely to land (its request's time plus the quickest of
        the last round trips), or None (nothing in flight, or no round trip seen yet)."""
        if self.in_flight is None or not self._round_trips:
            return None
        return self.in_flight[1] + min(self._round_trips)

    # -- observations out ---------------------------------------------------------------------------
    def wants_request(self, t_now: float) -> bool:
        if self.in_flight is not None:
            if t_now - self.in_flight[1] < self.config.request_timeout_s:
                return False
            self.timeouts += 1  # lost or stuck: ask again with a fresh observation
            self.in_flight = None
        if not self.schedule:
            return True
        newest = self.schedule.placed[-1].chunk
        return self.schedule.remaining(t_now) <= self.config.request_threshold * newest.horizon

    def request(self, obs: Any, instruction: str | None, t_obs: float, t_now: float) -> int:
        """Send `obs` (taken at `t_obs`) for inference; the first request of a run resets the policy."""
        self.seq += 1
        self.policy.request(obs, instruction, t_obs, self.seq, reset=self._reset_next)
        self.record.sent.add(clock.now() - t_obs)
        self._reset_next = False
        self.in_flight = (self.seq, t_now)
        self.requests += 1
        return self.seq

    # -- commands -----------------------------------------------------------------------------------
    def command(self, t_target: float) -> Sample | None:
        """The command for `t_target` (None before the first chunk); counts late ticks and events."""
        s = self.schedule.sample(t_target)
        if s is None:
            return None
        if s.late:
            self.late_ticks += 1
            if not self._late:
                self.late_events += 1
        self._late = s.late
        if self.filter is not None:
            s.action = self.filter(s.action, t_target)
        return s

    def applied(self, s: Sample, t_applied: float) -> None:
        """Record that `s` was sent to the robot at `t_applied`."""
        self.record.action_age.add(t_applied - s.t_obs)
        forward = self._first_pending.pop(s.seq, None)
        if forward is not None:
            self.record.first_action.add(t_applied - s.t_obs)
            self.record.overhead.add(t_applied - s.t_obs - forward)

    def stats(self) -> dict[str, Any]:
        r = self.record

        def pct(xs: Reservoir, q: float, scale: float = 1000.0) -> float | None:
            p = xs.percentile(q)
            return None if p is None else round(p * scale, 3)

        return {
            "requests": self.requests, "chunks": self.chunks, "timeouts": self.timeouts,
            "frame_misses": self.frame_misses,
            "late_events": self.late_events, "late_ticks": self.late_ticks,
            "first_action_ms_p50": pct(r.first_action, 50), "first_action_ms_p99": pct(r.first_action, 99),
            "action_age_ms_p50": pct(r.action_age, 50), "action_age_ms_p99": pct(r.action_age, 99),
            "forward_ms_p50": pct(r.forward, 50),
            "overhead_ms_p50": pct(r.overhead, 50), "overhead_ms_p99": pct(r.overhead, 99),
            "obs_sent_ms_p50": pct(r.sent, 50), "obs_to_policy_ms_p50": pct(r.queue_in, 50),
            "dropped_actions_p50": r.dropped.percentile(50),
        }
