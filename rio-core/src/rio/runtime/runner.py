"""Runs a node's loop on the server side, the same way under every middleware.

The middleware supplies the ring buffer the node writes, the request queue it reads and the thread
or process it runs in; this module supplies the loop (publish-only, request-only, combined, with the
complementary half optionally in a worker thread), its timing, the ready signal and API dispatch.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any

from rio import clock
from rio.errors import InvalidRequest
from rio.profiling.session import active_dir
from rio.profiling.trace import Trace
from rio.runtime.node import Node

log = logging.getLogger("rio.runtime.runner")

_IDLE_WAIT_S = 0.05  # how often a blocked request loop re-checks the exit event
_REPEAT_S = 5.0  # a request refused for the same reason is logged again at most this often
#: Node loops spin only this long before a deadline (node processes set a 1 ns timer slack, so the
#: OS sleep is already close); a longer spin would contend for the GIL with the API thread.
NODE_SPIN_S = 0.0002


class Dispatcher:
    """Executes remote `__api__` calls inside the node, serialized with its loop by one lock."""

    def __init__(self, node: Node, lock: threading.RLock):
        self.node, self.lock = node, lock
        self.allowed = type(node).remote_methods()

    def __call__(self, method: str, args: list | tuple, kwargs: dict) -> Any:
        if method not in self.allowed:
            client = set(type(self.node).__api__) - self.allowed
            hint = " (it is client-side)" if method in client else f"; remote API: {sorted(self.allowed)}"
            raise AttributeError(f"'{method}' is not a remote API method of node '{self.node.name}'{hint}")
        with self.lock:
            return getattr(self.node, method)(*args, **kwargs)


class NodeRunner:
    """The loop around a node. `run()` blocks until `exit_event` is set or the node raises."""

    def __init__(self, node: Node, *, lock: threading.RLock | None = None):
        self.node = node
        self.lock = lock or threading.RLock()
        self.shape = node.loop_shape()
        self.rejected = 0
        self._refusals: dict[str, list[Any]] = {}  # why -> [refused again since logged, when to log it again]
        self._worker_error: BaseException | None = None
        #: Spans of this node's work while profiling is on (`rio.profiling.enable`), else None.
        self._trace: Trace | None = None

    # -- one step of each half ----------------------------------------------------------------------
    def _publish_once(self) -> None:
        tr = self._trace
        with self.lock:
            if tr is None:
                sample = self.node.cycle()
            else:
                t0 = clock.now()
                sample = self.node.cycle()
                tr.span("read_state", "read_state", t0, clock.now())  # the profile's name for a node's cycle
        if sample is not None:
            self.node.ring_buffer.put(sample)

    def _handle_pending(self) -> None:
        tr = self._trace
        for req in self.node.request_queue.get_all():
            with self.lock:
                t0 = clock.now() if tr is not None else 0.0
                try:
                    self.node.handle_request(req)
                except InvalidRequest as e:  # the node refused it: report, keep serving
                    self.rejected += 1
                    self._refused(str(e))
                if tr is not None:
                    tr.span("request", "handle_request", t0, clock.now())

    def _refused(self, why: str) -> None:
        """Log a refused request: a new reason at once, the same one again at most every `_REPEAT_S` with how
        many more there were. A faulted or disabled device refuses every command of a control loop (30 to 500
        a second); the first line says why, the run's summary says the rest."""
        now = clock.now()
        seen = self._refusals.get(why)
        if seen is None or now >= seen[1]:
            more = f" ({seen[0]} more like it since)" if seen is not None and seen[0] else ""
            log.warning("%s%s", why, more)
            self._refusals[why] = [0, now + _REPEAT_S]
            if len(self._refusals) > 64:  # reasons that name values: keep the newest
                self._refusals.pop(next(iter(self._refusals)))
        else:
            seen[0] += 1
            log.debug("%s", why)

    # -- loops --------------------------------------------------------------------------------------
    def _pub_loop(self, with_requests: bool) -> None:
        arrived = None if with_requests else self.node.arrival_event()
        if arrived is not None:
            self._arrival_loop(arrived)
            return
        rate = clock.Rate(self.node.rate_hz, spin_s=NODE_SPIN_S)
        ev = self.node.exit_event
        while not ev.is_set():
            if with_requests:
                self._handle_pending()
            self._publish_once()
            rate.sleep()
        self.overruns = rate.overruns

    def _arrival_loop(self, arrived: threading.Event) -> None:
        """Publish each sample as it arrives (a camera's grab thread sets `arrived`), not on a clock: a
        frame polled at the camera's own rate waits half a frame period on average, and is sometimes
        skipped when the two clocks drift."""
        ev = self.node.exit_event
        while not ev.is_set():
            if arrived.wait(_IDLE_WAIT_S):
                arrived.clear()  # before reading: a frame landing meanwhile sets it again
                self._publish_once()

    def _req_loop(self) -> None:
        q, ev = self.node.request_queue, self.node.exit_event
        while not ev.is_set():
            if q.wait(_IDLE_WAIT_S):
                self._handle_pending()

    def _idle_loop(self) -> None:
        self.node.exit_event.wait()

    def _guarded(self, fn: Callable[[], None]) -> Callable[[], None]:
        def run() -> None:
            try:
                fn()
            except BaseException as e:  # surfaced by run(); stop the main loop too
                self._worker_error = e
                self.node.exit_event.set()
        return run

    def run(self, on_ready: Callable[[], None]) -> None:
        directory = active_dir()
        if directory is None:
            self._run(on_ready)
            return
        self._trace = Trace(process=f"node {self.node.name}")
        try:
            self._run(on_ready)
        finally:
            try:
                self._trace.write_part(directory)
            except Exception as e:  # profiling must never turn a clean stop into an error
                log.warning("node '%s': could not write its profile trace to %s: %s", self.node.name, directory, e)

    def _run(self, on_ready: Callable[[], None]) -> None:
        node = self.node
        node.open()
        try:
            node.opened()
            has_pub = node.ring_buffer is not None
            has_req = node.request_queue is not None
            if has_pub:
                self._publish_once()  # clients may read as soon as the node is ready
            main: Callable[[], None]
            worker: Callable[[], None] | None = None
            if has_pub and has_req and node.worker == "req":
                main, worker = (lambda: self._pub_loop(False)), self._req_loop
            elif has_pub and has_req and node.worker == "pub":
                main, worker = self._req_loop, (lambda: self._pub_loop(False))
            elif has_pub and (self.shape != "req" or not has_req):
                main = lambda: self._pub_loop(has_req and self.shape == "pubreq")  # noqa: E731
            elif has_req:
                main = self._req_loop
            else:
                main = self._idle_loop
            t = None
            if worker is not None:
                t = threading.Thread(target=self._guarded(worker), name=f"rio-{node.name}-worker", daemon=True)
                t.start()
            on_ready()
            main()
            if t is not None:
                node.exit_event.set()
                t.join(timeout=2.0)
            if self._worker_error is not None:
                raise self._worker_error
        finally:
            try:
                node.closing()
            finally:
                node.close()
