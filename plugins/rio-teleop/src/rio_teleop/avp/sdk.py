"""avp-stream's `VisionProStreamer`, fitted to a RIO node. Imports avp_stream: only `node.load_sdk()`
imports this module (inside `open()`), never the plugin's spec code.

What the SDK does (avp-stream 2.51, same-network mode, `VisionProStreamer(ip=...)`):

- its constructor starts an HTTP "info server" on 0.0.0.0:8888 (a daemon thread; `cleanup()` never stops
  it) that tells the app where a WebRTC video/audio/simulation stream is; then it starts its gRPC thread
  (`stream()`: dial `{ip}:12345`, wait up to 5 s for the channel, send the discovery request carrying
  this machine's address and the library version, then read the app's `HandUpdate` stream for ever;
  on an error retry, 10 attempts per call, backing off 0.5 s, 1 s, 2 s ... 128 s) and then blocks
  until the first sample arrives, printing a warning every 10 s, with no timeout;
- each update is turned into `latest` (`_process_hand_update`): wrists and head times YUP2ZUP, finger
  joints as sent (relative to the wrist); `get_latest()` wraps it (`TrackingData`, whose `.left` /
  `.right` compose wrist @ joint: world-frame joints);
- importing `avp_stream.streamer` registers SIGINT/SIGTERM handlers (when imported in the main thread)
  and an atexit hook; `node.load_sdk()` puts the process's own signal handlers back.

What `Streamer` changes, and why (everything else is the SDK's own code, unmodified: the gRPC dialling
and retries, the discovery request, the message parsing and frame conversion, `get_latest()`):

- `_start_info_server`: not started. It only serves WebRTC video, which this node does not use, and would
  hold port 8888 on every interface for the life of the process (two streamers, or two test processes,
  would fight over it);
- `_start_hand_tracking`: starts the SDK's `stream()` in a thread of ours and returns; the node waits for
  the first sample itself, with a timeout. When the SDK's `stream()` gives up (its 10 attempts spent:
  minutes with the app closed) ours calls it again, so the node reconnects whenever the app comes back;
- `_log`: the SDK's messages go to the `rio_teleop.avp.sdk` logger (debug) instead of stdout; the last
  ones are kept for the node's error messages;
- `_process_hand_update`: the SDK's, plus the arrival time and count of each sample; an update without
  hands (the app's answer to a library version it refuses; the SDK fails on it) is counted instead;
- stopping: the SDK has no way to end its gRPC thread: its channel is a local variable of `stream()` and
  its retry loop catches every `Exception` (it would dial again). So `_log`, called by `stream()` at every
  step of a connection, notes that frame's `channel`; `stop()` closes it, which ends a blocked read at
  once (the call is cancelled: the SDK logs the error, and there) or a channel wait when it times out
  (at most the SDK's 5 s); at that next log line, on that thread, the channel is closed again if the
  SDK has not, and `Closed` is raised: a BaseException, which passes the SDK's handlers and ends our
  thread. A thread asleep in the SDK's back-off ends when the sleep does; it owns no socket by then.
"""

from __future__ import annotations

import collections
import logging
import sys
import threading
from typing import Any

import grpc
from avp_stream.streamer import JOINT_NAMES, YUP2ZUP, VisionProStreamer

from rio import clock

from .loader import GRPC_PORT

log = logging.getLogger("rio_teleop.avp.sdk")

__all__ = ["GRPC_PORT", "JOINT_NAMES", "YUP2ZUP", "Closed", "Streamer"]


class Closed(BaseException):
    """Raised on the SDK's gRPC thread once the streamer is stopped (see the module docstring)."""


class Streamer(VisionProStreamer):
    """`VisionProStreamer(ip, record=False, verbose=False)` in same-network gRPC mode, returning at once
    (the first update is awaited with `wait_first`), quiet, and stoppable with `stop()`."""

    def __init__(self, ip: str):
        self.rio_closed = threading.Event()
        self.rio_arrived = threading.Event()  # an update came: a sample, or an empty one (see rio_empty)
        self.rio_empty = 0  # updates without hands: what the app sends a library version it refuses
        self.rio_thread: threading.Thread | None = None
        self.rio_messages: collections.deque[str] = collections.deque(maxlen=12)
        self.rio_count = 0
        self.rio_t_sample = -float("inf")
        self.rio_channel: grpc.Channel | None = None
        super().__init__(ip=ip, record=False, verbose=False, ht_backend="grpc", origin="avp")

    # -- the SDK's hooks ---------------------------------------------------------------------------
    def _start_info_server(self, port: int = 8888) -> None:
        """Not started: it serves WebRTC connection info only (see the module docstring)."""

    def _start_hand_tracking(self) -> None:
        self.rio_thread = threading.Thread(target=self._rio_run, name=f"avp-stream {self.ip}", daemon=True)
        self.rio_thread.start()

    def _log(self, message: str, force: bool = False) -> None:
        if threading.current_thread() is self.rio_thread:
            channel = sys._getframe(1).f_locals.get("channel")  # stream()'s, when it has one
            if isinstance(channel, grpc.Channel):
                self.rio_channel = channel
            if self.rio_closed.is_set():
                if isinstance(channel, grpc.Channel):
                    channel.close()
                raise Closed
        text = str(message).strip()
        if text:
            self.rio_messages.append(text)
            log.debug("%s: %s", self.ip, text)

    def _process_hand_update(self, hand_update: Any, source: str = "grpc") -> None:
        if self.rio_closed.is_set():
            raise Closed
        if not hand_update.right_hand.skeleton.jointMatrices and not hand_update.left_hand.skeleton.jointMatrices:
            self.rio_empty += 1  # the SDK fails on these (it logs why); an app blocking old clients sends them
            self.rio_arrived.set()
            return
        before = self.latest
        super()._process_hand_update(hand_update, source)
        if self.latest is not before:
            self.rio_t_sample = clock.now()
            self.rio_count += 1
            self.rio_arrived.set()

    # -- ours --------------------------------------------------------------------------------------
    def _rio_run(self) -> None:
        try:
            while not self.rio_closed.is_set():
                self.stream()  # the SDK's gRPC loop; returns once its retries are spent
                self.rio_closed.wait(1.0)
        except Closed:
            pass

    def wait_first(self, timeout: float) -> bool:
        """Whether an update arrived within `timeout` seconds (or before): a sample (`latest`), or an empty
        update (`rio_empty`)."""
        return self.rio_arrived.wait(timeout)

    def last_messages(self, n: int = 3) -> list[str]:
        return list(self.rio_messages)[-n:]

    def stop(self, timeout: float = 1.0) -> bool:
        """End the gRPC thread (see the module docstring) and run the SDK's `cleanup()`. Waits up to
        `timeout` s for the thread; returns whether it has ended (a streaming one ends at its next update)."""
        self.rio_closed.set()
        channel = self.rio_channel
        if channel is not None:
            channel.close()  # cancels a call in progress: the SDK's thread wakes up, logs it, and ends there
        try:
            self.cleanup()  # the SDK's: WebRTC/signalling (unused here) and its list of live streamers
        except Exception as e:  # noqa: BLE001 - cleanup is best effort
            log.debug("%s: cleanup failed: %s", self.ip, e)
        t = self.rio_thread
        if t is None or t is threading.current_thread():
            return t is None
        t.join(timeout)
        return not t.is_alive()
