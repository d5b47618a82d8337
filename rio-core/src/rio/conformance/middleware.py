"""Middleware conformance kit: the cases every middleware must pass, as one inheritable test class.

    from rio.conformance.middleware import MiddlewareConformance

    class TestMyMiddleware(MiddlewareConformance):
        middleware = "mymw"  # a registered middleware name, or a Middleware instance

Each case goes through the public API only (serve / connect / ServerManager) with the nodes from
`rio.testing`, and the same cases run on every built-in middleware (rio-core/tests/test_conformance.py).
Cases that need the shared echo server (`running`) share one per class; the cases that start their
own servers first stop it, so no two servers of the same name run at once.

Without writing a file: `pytest --rio-middleware NAME` (see `rio.conformance.pytest_plugin`).

The flood cases (`test_flood_*`) run on middlewares built on RIO's network protocol
(`rio.middleware.protocol`): connected clients there send calls or requests without waiting for their
answers, as a flooding peer would (authenticated, when the middleware has keys).
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
import time
from collections.abc import Iterator
from typing import Any, ClassVar

import numpy as np
import pytest

import rio
from rio import ServerManager, connect, serve
from rio.conformance.process import assert_no_shm_left, child_pids, shm_entries
from rio.middleware.protocol import NetworkClient, NetworkConfig
from rio.middleware.protocol import messages as msg
from rio.middleware.protocol.credits import NoCredits
from rio.runtime import wire
from rio.runtime.transport import Middleware
from rio.testing import EchoNode, FailingOpenNode, ImageNode, no_new_threads, wait_until

__all__ = ["FloodConformance", "MiddlewareConformance", "send_in_turn"]


def _label(mw: str | Middleware) -> str:
    return mw if isinstance(mw, str) else type(mw).name


def _process_per_node(mw: str | Middleware) -> bool:
    if isinstance(mw, Middleware):
        return mw.process_per_node
    from rio.plugins import get_middleware

    return bool(get_middleware(mw).process_per_node)


def send_in_turn(node: Any, deadline_s: float = 5.0, /, **fields: Any) -> None:
    """`node.send_request(**fields)` (`node`: a connected client) as a well-behaved sender does it: on a
    network middleware a request with no credit left fails at once (NoCredits, nothing sent), so try again
    until the node has acknowledged earlier ones; any other error, or no credit within `deadline_s`, is raised."""
    t_end = time.monotonic() + deadline_s
    while True:
        try:
            return node.send_request(**fields)
        except NoCredits:
            if time.monotonic() > t_end:
                raise
            time.sleep(0.0005)


class _SharedEcho:
    """The class's echo server and one client of it, started on first use and stopped on demand
    (before a case that starts its own servers) or at the end of the class."""

    def __init__(self, mw: str | Middleware):
        self.mw = mw
        self._stack: contextlib.ExitStack | None = None
        self._value: tuple[Any, ServerManager, Any] | None = None

    def get(self) -> tuple[Any, ServerManager, Any]:
        if self._value is None:
            with contextlib.ExitStack() as stack:
                mgr = stack.enter_context(ServerManager(self.mw, [serve(EchoNode, name="echo", rate_hz=200)]))
                client = stack.enter_context(connect(EchoNode, self.mw, name="echo", rate_hz=200))
                self._stack, self._value = stack.pop_all(), (self.mw, mgr, client)
        return self._value

    def stop(self) -> None:
        stack, self._stack, self._value = self._stack, None, None
        if stack is not None:
            stack.close()


class _Flooder:
    """A connected client that sends calls (or requests) in bursts without waiting for their answers, from
    one thread, and counts the refusals it hears (TooManyCalls, FULL): a peer flooding the node."""

    def __init__(self, mw: str | Middleware, name: str, kind: str, burst: int):
        self.client = connect(EchoNode, mw, name=name, rate_hz=20)
        self.kind, self.burst, self.refused, self.sent = kind, burst, 0, 0
        self.error: BaseException | None = None
        t = self.client._transport  # type: ignore[attr-defined]  # (a NodeClient, typed as the node)
        if not isinstance(t, NetworkClient):
            self.client.close()
            pytest.skip("floods are sent through rio.middleware.protocol: this middleware does not use it")
        layout = EchoNode(rate_hz=20).layouts()[1]
        assert layout is not None
        record = layout.encode({"q": np.zeros(6), "client": -1, "seq": 0}, fill_timestamp=0.0).tobytes()
        self._body = ((lambda i: msg.REQUEST_ID.pack(i) + record) if kind == "requests"
                      else (lambda i: wire.pack_call(i, "sleep", [0.02], {})))
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, args=(t,), name=f"rio-kit-flood-{name}", daemon=True)
        self._thread.start()

    def _run(self, t: NetworkClient) -> None:
        kind, answer = (msg.REQUEST, msg.ACK) if self.kind == "requests" else (msg.CALL, msg.REPLY)
        try:
            while not self._stop.is_set():
                for _ in range(self.burst):
                    self.sent += 1
                    t._send(kind, self._body(self.sent))
                while (body := t._recv(answer)) is not None:  # what arrived, then a liveness poll's wait
                    got = wire.unpack(body)
                    if answer == msg.ACK:
                        self.refused += got[1] == msg.FULL
                    else:
                        self.refused += not got[1] and got[2][0] == "TooManyCalls"
        except BaseException as e:  # reported by stop()
            self.error = e

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(30)
        self.client.close()
        assert self.error is None, f"the flooder failed: {self.error!r}"


@contextlib.contextmanager
def _flood(mw: str | Middleware, name: str, kind: str, peers: int, burst: int) -> Iterator[list[_Flooder]]:
    flooders: list[_Flooder] = []
    try:
        for _ in range(peers):
            flooders.append(_Flooder(mw, name, kind, burst))
        time.sleep(0.5)  # the node's queues fill
        yield flooders
    finally:
        for f in flooders:
            f.stop()


class _Kit:
    """What every kit class shares: the middleware under test and its servers (see MiddlewareConformance)."""

    #: Registered middleware name (as in `rio plugins list`) or a Middleware instance.
    middleware: ClassVar[str | Middleware | None] = None
    #: How long a case waits for an effect (new samples, a request applied) before it fails (s).
    wait_s: ClassVar[float] = 3.0

    # -- fixtures -----------------------------------------------------------------------------------
    @pytest.fixture(scope="class")
    @classmethod
    def mw(cls, request: pytest.FixtureRequest) -> str | Middleware:
        """The middleware under test: the class's `middleware`, else `--rio-middleware NAME`."""
        mw = getattr(request.cls, "middleware", None) or request.config.getoption("rio_middleware", None)
        if mw is None:
            pytest.skip(f"no middleware to test: set `middleware = ...` on {request.cls.__name__} "
                        "or pass --rio-middleware NAME")
        return mw

    @pytest.fixture(scope="class")
    @classmethod
    def shared_echo(cls, mw: str | Middleware) -> Iterator[_SharedEcho]:
        shared = _SharedEcho(mw)
        try:
            yield shared
        finally:
            shared.stop()

    @pytest.fixture
    def running(self, shared_echo: _SharedEcho) -> tuple[Any, ServerManager, Any]:
        """One echo server per class, shared by the non-destructive cases: (mw, manager, client)."""
        return shared_echo.get()

    @pytest.fixture
    def own_servers(self, shared_echo: _SharedEcho) -> None:
        """For cases that start their own servers: the shared echo server is stopped first."""
        shared_echo.stop()

class FloodConformance(_Kit):
    """The flood cases alone (also part of MiddlewareConformance): for running them again under other
    settings, e.g. with keys, where the flooding peers are authenticated ones."""

    # -- floods: a peer that floods is refused or slowed, every other client is answered in time ------
    #: Flooding peers in the many-peers cases; each keeps up to `max_pending_per_peer` calls queued.
    flood_peers: ClassVar[int] = 16
    #: How long a call or request of a well-behaved client may take while a flood runs (s): generous,
    #: against the ~0.3 s a round of the flooders' slow calls takes.
    flood_answer_s: ClassVar[float] = 1.0

    def _answered_in_time(self, mw: str | Middleware, name: str, flooders: list[_Flooder], what: str) -> None:
        with connect(EchoNode, mw, name=name, rate_hz=20) as c:
            took: list[float] = []
            for i in range(10):
                t0 = time.monotonic()
                assert c.echo(i) == i
                t1 = time.monotonic()
                send_in_turn(c, self.flood_answer_s, q=np.full(6, float(i)), client=5, seq=i)
                took += [t1 - t0, time.monotonic() - t1]
            assert max(took) < self.flood_answer_s, (
                f"while {len(flooders)} peer(s) flooded {what}, calls took up to {max(took[::2]):.2f} s and requests "
                f"up to {max(took[1::2]):.2f} s")
            assert wait_until(lambda: [5, 9] in c.handled(), timeout=self.wait_s), "requests lost in the flood"
        assert sum(f.refused for f in flooders) > 0, f"the flood of {what} was never refused: no flood at all?"

    @pytest.mark.usefixtures("own_servers")
    def test_flood_of_slow_calls_from_many_peers(self, mw):
        """Many peers (zmq identities, zenoh clients listening for their own replies, portal connections)
        each keep slow calls queued, more than the node queues in all: they hear TooManyCalls, and another
        client's calls and requests are answered within `flood_answer_s` throughout."""
        with ServerManager(mw, [serve(EchoNode, name="flooded", rate_hz=20)]):
            with _flood(mw, "flooded", "calls", self.flood_peers, burst=8) as flooders:
                self._answered_in_time(mw, "flooded", flooders, "slow calls")

    @pytest.mark.usefixtures("own_servers")
    def test_flood_of_slow_calls_from_one_peer(self, mw):
        with ServerManager(mw, [serve(EchoNode, name="flooded", rate_hz=20)]):
            with _flood(mw, "flooded", "calls", 1, burst=64) as flooders:
                self._answered_in_time(mw, "flooded", flooders, "slow calls")

    @pytest.mark.usefixtures("own_servers")
    def test_flood_of_requests(self, mw):
        """Peers send requests as fast as they can, keeping the node's request queue full: they hear FULL
        (QueueFull), and another client's requests still take the next free slots, in time."""
        with ServerManager(mw, [serve(EchoNode, name="flooded", rate_hz=20)]):
            with _flood(mw, "flooded", "requests", 4, burst=64) as flooders:
                self._answered_in_time(mw, "flooded", flooders, "requests")

class MiddlewareConformance(FloodConformance):
    """Base class of the middleware conformance cases. Subclass it as `Test...` and set `middleware`.

    Not named `Test*`, so importing it into a test module does not collect it there; pytest collects
    the inherited cases from each subclass. `middleware = None` takes the name from `--rio-middleware`.
    A Middleware instance of a process-per-node middleware is re-created in each node's spawned
    process from its class, so that class must live in an importable module (not a test file).
    """

    # -- cases on the shared echo server ------------------------------------------------------------
    def test_latest_state_advances_and_last_k_is_ordered(self, running):
        """A network client's mirror holds what reached it: a state stream may skip a sample (one published
        before this client's subscription reached the server, or dropped under congestion: the newest
        matters more than every one), never repeats or reorders one. A shared ring skips none."""
        _, _, c = running
        k = 5
        s1 = c.get_state()
        # k + 3 newer samples: the mirror then holds k that arrived after s1 even if a few were skipped
        assert wait_until(lambda: c.get_state()["tick"] > s1["tick"] + k + 3, timeout=self.wait_s), (
            "timed out waiting for new samples")
        s2 = c.get_state()
        assert s2["timestamp"] > s1["timestamp"]
        np.testing.assert_array_equal(s2["q"], np.full(6, float(s2["tick"])))
        last = c.get_state(k=k)
        assert last["q"].shape == (k, 6) and last["tick"].shape == (k,)
        steps = np.diff(last["tick"])
        if isinstance(c._transport, NetworkClient):
            assert np.all(steps >= 1), last["tick"]
        else:
            assert np.all(steps == 1), last["tick"]
        assert np.all(np.diff(last["timestamp"]) > 0)
        assert last["tick"][-1] >= s2["tick"]

    def test_get_state_into_preallocated_out(self, running):
        _, _, c = running
        out = {"q": np.empty(6), "last": np.empty(6)}
        res = c.get_state(out=out)
        assert res["q"] is out["q"] and res["last"] is out["last"]
        np.testing.assert_array_equal(out["q"], np.full(6, float(res["tick"])))  # one consistent sample

    def test_two_clients_concurrent_requests_none_lost(self, running):
        mw, _, _ = running
        n = 200
        before = len(running[2].handled())
        errors: list[BaseException] = []
        refused = {1: 0, 2: 0}

        def producer(cid: int) -> None:
            try:
                with connect(EchoNode, mw, name="echo", rate_hz=200) as c:
                    for seq in range(n):
                        send_in_turn(c, q=np.full(6, float(seq)), client=cid, seq=seq)
                    t = c._transport  # type: ignore[attr-defined]  # (a NodeClient, typed as the node)
                    if isinstance(t, NetworkClient):  # every acknowledgement in: a refusal is counted, not lost
                        stats = t.request_stats(wait_s=max(self.wait_s, 15.0))
                        assert stats.acknowledged + stats.refused == n, stats
                        refused[cid] = stats.refused
            except BaseException as e:
                errors.append(e)

        threads = [threading.Thread(target=producer, args=(cid,)) for cid in (1, 2)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert not errors, errors
        c = running[2]
        # none lost, not how fast: 400 queued requests drain at the node's pace, which a loaded machine slows;
        # a request the node's queue had no room for within its put timeout (a node stalled for a second) was
        # refused, its sender told (FULL): counted, never silently gone
        accepted = 2 * n - sum(refused.values())
        assert accepted > n, refused
        assert wait_until(lambda: len(c.handled()) - before >= accepted, timeout=max(self.wait_s, 15.0)), (
            f"timed out waiting for all requests handled ({len(c.handled()) - before} of {accepted}; "
            f"refused {refused})")
        got = [tuple(x) for x in c.handled()[before:]]
        assert len(got) == accepted, (len(got), refused)
        for cid in (1, 2):
            seqs = [s for k, s in got if k == cid]
            assert len(seqs) == n - refused[cid] and seqs == sorted(set(seqs)), (
                f"client {cid} lost or reordered requests (refused {refused[cid]})")

    def test_request_reaches_node_state(self, running):
        _, _, c = running
        target = np.arange(6, dtype=np.float64) * 0.1
        c.send_request(q=target, client=0, seq=0)
        assert wait_until(lambda: np.allclose(c.get_state()["last"], target), timeout=self.wait_s), (
            "timed out waiting for request applied")

    def test_api_call_returns_value(self, running):
        _, _, c = running
        payload = np.random.default_rng(0).integers(0, 255, 2048, dtype=np.uint8)
        got = c.echo(payload)
        assert isinstance(got, np.ndarray) and got.dtype == np.uint8
        np.testing.assert_array_equal(got, payload)
        nested = {"a": [1, 2.5, "x"], "b": np.eye(3, dtype=np.float32)}
        back = c.echo(nested)
        assert back["a"] == [1, 2.5, "x"]
        np.testing.assert_array_equal(back["b"], nested["b"])

    def test_api_calls_with_large_and_many_arrays_from_two_threads(self, running):
        """Arrays far larger than a 2 kB payload, several per call, from two threads of one client:
        every reply belongs to its own call."""
        _, _, c = running
        rng = np.random.default_rng(1)
        big = rng.random((240, 320, 3)).astype(np.float32)  # 900 kB
        np.testing.assert_array_equal(c.echo(big), big)
        errors: list[BaseException] = []

        def worker(seed: int) -> None:
            try:
                for i in range(40):
                    x = np.full((seed, 7), float(i), np.float64)
                    got = c.echo([x, np.arange(seed, dtype=np.int16)])
                    np.testing.assert_array_equal(got[0], x)
                    np.testing.assert_array_equal(got[1], np.arange(seed, dtype=np.int16))
                    np.testing.assert_array_equal(c.echo(x), x)
            except BaseException as e:  # noqa: BLE001 - reported by the main thread
                errors.append(e)

        threads = [threading.Thread(target=worker, args=(seed,)) for seed in (3, 5000)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(60)
        assert not errors, errors

    def test_exception_inside_node_surfaces_with_name(self, running):
        _, _, c = running
        with pytest.raises(rio.NodeError) as ei:
            c.fail("gripper jammed")
        assert ei.value.node == "echo" and ei.value.exc_type == "ValueError"
        assert "echo" in str(ei.value) and "gripper jammed" in str(ei.value)
        assert c.echo(7) == 7  # still serving

    @pytest.mark.parametrize("bad, field", [
        ({"q": np.zeros(5), "client": 0, "seq": 0}, "q"),
        ({"q": np.array([0, 0, np.nan, 0, 0, 0]), "client": 0, "seq": 0}, "q"),
        ({"q": np.full(6, np.inf), "client": 0, "seq": 0}, "q"),
        ({"q": np.zeros(6), "client": 0}, "seq"),
        ({"q": np.zeros(6), "client": 0, "seq": 0, "speed": 1.0}, "speed"),
        ({"q": np.zeros(6), "client": 0.5, "seq": 0}, "client"),
    ])
    def test_bad_requests_rejected_node_keeps_serving(self, running, bad, field):
        _, _, c = running
        with pytest.raises(rio.InvalidRequest) as ei:
            c.send_request(bad)
        assert ei.value.node == "echo" and ei.value.field == field
        assert f"'{field}'" in str(ei.value)
        tick = c.get_state()["tick"]
        assert wait_until(lambda: c.get_state()["tick"] > tick, timeout=self.wait_s), (
            "timed out waiting for node still publishing")
        good = np.full(6, 0.25)
        c.send_request(q=good, client=9, seq=1)
        assert wait_until(lambda: np.allclose(c.get_state()["last"], good), timeout=self.wait_s), (
            "timed out waiting for valid request after rejects")

    def test_unknown_api_method_is_clear(self, running):
        _, _, c = running
        with pytest.raises(AttributeError, match="no API method 'home'"):
            c.home()

    # -- cases that start their own servers ---------------------------------------------------------
    @pytest.mark.usefixtures("own_servers")
    def test_image_stream(self, mw):
        with ServerManager(mw, [serve(ImageNode, name="cam", rate_hz=60)]):
            with connect(ImageNode, mw, name="cam", rate_hz=60) as cam:
                f1 = cam.get_state()
                assert f1["rgb"].shape == (480, 640, 3) and f1["rgb"].dtype == np.uint8
                assert wait_until(lambda: cam.get_state()["frame"] >= f1["frame"] + 5, timeout=self.wait_s), (
                    "timed out waiting for new frames")
                s = cam.get_state()
                assert s["rgb"][0, 0, 0] == s["frame"] % 4

    @pytest.mark.usefixtures("own_servers")
    def test_sigkill_reported_within_one_second_and_cleaned_up(self, mw):
        if not _process_per_node(mw):
            pytest.skip(f"the {_label(mw)} middleware runs nodes as threads: no server process to kill")
        shm_before, children_before = shm_entries(), child_pids()
        with ServerManager(mw, [serve(EchoNode, name="echo")]) as mgr:
            with connect(EchoNode, mw, name="echo") as c:
                assert c.echo(1) == 1
                os.kill(mgr.pids()["echo"], signal.SIGKILL)
                t0 = time.monotonic()
                with pytest.raises(rio.NodeDiedError) as ei:
                    while time.monotonic() - t0 < 5:
                        c.get_state()
                        time.sleep(0.001)
                assert time.monotonic() - t0 <= 1.0, "death noticed too late"
                assert "echo" in str(ei.value)
                t1 = time.monotonic()
                with pytest.raises(rio.NodeDiedError):
                    c.echo(2)
                assert time.monotonic() - t1 <= 1.0
                with pytest.raises(rio.NodeDiedError):
                    c.send_request(q=np.zeros(6), client=0, seq=0)
        assert child_pids() <= children_before, "child process left behind"
        assert_no_shm_left(mgr, shm_before)

    @pytest.mark.usefixtures("own_servers")
    def test_clean_exit_leaves_nothing(self, mw):
        shm_before, children_before = shm_entries(), child_pids()
        with ServerManager(mw, [serve(EchoNode, name="a"), serve(ImageNode, name="b")]) as mgr:
            with connect(EchoNode, mw, name="a") as a, connect(ImageNode, mw, name="b") as b:
                a.send_request(q=np.ones(6), client=0, seq=0)
                assert b.get_state()["rgb"].shape == (480, 640, 3)
        assert child_pids() <= children_before
        assert_no_shm_left(mgr, shm_before)

    @pytest.mark.usefixtures("own_servers")
    def test_startup_failure_names_node_and_cleans_up(self, mw):
        shm_before, children_before = shm_entries(), child_pids()
        mgr = ServerManager(mw, [serve(EchoNode, name="ok"), serve(FailingOpenNode, name="cam0")])
        with pytest.raises(rio.RioError) as ei:
            with mgr:
                pass
        assert "cam0" in str(ei.value) and "/dev/ttyFAKE" in str(ei.value)
        assert child_pids() <= children_before
        assert_no_shm_left(mgr, shm_before)

    @pytest.mark.usefixtures("own_servers")
    def test_no_thread_outlives_its_client_or_server(self, mw, tmp_path):
        """Every thread a client started has ended once it is closed, after calls, requests and reads; so has
        every thread of a server made in this process (as the thread middleware's are; also checked for the
        middlewares built on rio.middleware.protocol, whose servers run in other programs too). A thread may
        take `thread_grace_s` to go: zenoh ends its callback threads shortly after their subscriptions."""
        from rio.plugins import get_middleware
        from rio.runtime.runner import Dispatcher
        from rio.runtime.transport import NodeLayouts, machine_id

        def use(address: dict[str, Any] | None = None) -> None:
            with connect(EchoNode, mw, name="tidy", address=address) as c:
                assert c.echo(1) == 1 and c.get_state()["tick"] >= 1
                c.send_request(q=np.zeros(6), client=0, seq=0)

        with ServerManager(mw, [serve(EchoNode, name="tidy")]):
            for _ in range(2):
                with no_new_threads(self.thread_grace_s):  # the client's threads only: its server runs elsewhere
                    use()
        middleware = mw if isinstance(mw, Middleware) else get_middleware(mw)()
        if middleware.process_per_node and not isinstance(middleware.config, NetworkConfig):
            return  # its servers run only in node processes of their own
        node = EchoNode()
        node.name = "tidy"
        layouts = NodeLayouts.of(node)
        with no_new_threads(self.thread_grace_s):
            server = middleware.make_server(node, layouts, middleware.prepare(layouts, str(tmp_path)))
            try:  # stamped as ServerManager stamps a node's address: the server runs in this process
                address = {**server.start(Dispatcher(node, threading.RLock())), "pid": os.getpid(),
                           "machine": machine_id()}
                server.ring_buffer.put(node.read_state())
                use(address)  # (its server's threads for this client may end after the client's close)
            finally:
                server.close()

    #: How long a thread may take to end after its client or server was closed (s).
    thread_grace_s: ClassVar[float] = 1.0

    def test_connect_without_server_is_clear(self, mw):
        with pytest.raises(rio.NodeDiedError, match="ghost"):
            connect(EchoNode, mw, name="ghost")


class TestSelectedMiddleware(MiddlewareConformance):
    """The kit against `--rio-middleware NAME`; collected only where this module itself is collected
    (`pytest --rio-middleware NAME` points pytest here), skipped without the option."""

    middleware = None
