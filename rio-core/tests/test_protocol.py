"""RIO's network protocol (`rio.middleware.protocol`) without sockets: its fair queues, its request flow
control and both of its ends, joined here by an in-memory transport (what zmq, zenoh and portal replace)."""

from __future__ import annotations

import queue
import threading
import time
import warnings

import numpy as np
import pytest

import rio
from rio.errors import ConfigError, InvalidRequest, NodeDiedError, NodeError, NodeTimeout, QueueFull
from rio.middleware.protocol import NetworkClient, NetworkConfig, NetworkServer
from rio.middleware.protocol import messages as m
from rio.middleware.protocol.credits import NoCredits
from rio.middleware.protocol.fair import FairQueue
from rio.middleware.protocol.requests import RequestIntake
from rio.runtime import wire
from rio.runtime.buffers import RequestQueue
from rio.runtime.layout import Layout
from rio.runtime.node import remote
from rio.runtime.runner import Dispatcher
from rio.runtime.transport import NodeLayouts
from rio.testing import EchoNode, wait_until


# -- fair queues -----------------------------------------------------------------------------------------
def test_work_is_taken_round_robin_across_peers():
    q = FairQueue(per_peer=8, total=64)
    for i in range(5):
        q.put("flood", f"f{i}")
    q.put("a", "a0")
    q.put("b", "b0")
    order = [q.get(0)[1] for _ in range(7)]
    assert order == ["f0", "a0", "b0", "f1", "f2", "f3", "f4"]  # the newcomers wait one turn, not five
    assert q.get(0) is None


def test_a_peer_over_its_bound_is_refused_and_the_biggest_gives_way_to_a_newcomer():
    q = FairQueue(per_peer=3, total=6)
    assert [q.put("x", i) for i in range(3)] == [[]] * 3
    assert q.put("x", 3) == [("x", 3)]  # its own bound
    assert [q.put("y", i) for i in range(3)] == [[]] * 3  # total reached: 3 + 3
    assert q.put("z", "z0") == [("x", 2)]  # x holds 3 >= 0 + 2: its newest gives way
    assert q.put("z", "z1") == [("y", 2)]  # now y holds the most
    assert q.put("z", "z2") == [("z", "z2")]  # x, y and z hold 2 each: nobody gives way to z's third
    assert len(q) == 6


def test_known_peers_outrank_a_swarm_of_strangers():
    known = {"real"}
    q = FairQueue(per_peer=8, total=4, known=lambda p: p in known)
    for i in range(4):
        assert q.put(f"made-up-{i}", i) == []
    assert q.put("made-up-9", 9) == [("made-up-9", 9)]  # strangers holding one each: the swarm is full
    (refused,) = q.put("real", "call")
    assert refused[0].startswith("made-up-")  # a stranger gives way to a known peer
    got = [q.get(0) for _ in range(4)]
    assert ("real", "call") in got


def test_expire_drop_and_close():
    q = FairQueue(per_peer=8, total=64)
    for i in range(3):
        q.put("a", i)
    q.put("b", 10)
    assert q.expire(lambda item: item < 2) == [("a", 0), ("a", 1)]
    assert q.drop("b") == [10] and len(q) == 1
    t = threading.Thread(target=lambda: (q.get(0), got.append(q.get())))
    got: list = []
    t.start()
    time.sleep(0.05)
    assert q.close() == [] and (t.join(2) or not t.is_alive()) and got == [None]
    assert q.put("a", 5) == [("a", 5)]  # closed: refuses


# -- request flow control ----------------------------------------------------------------------------------
_LAYOUT = Layout({"x": np.zeros(2)}, owner="arm", what="request")


def _record(x: float) -> memoryview:
    return memoryview(_LAYOUT.encode({"x": np.full(2, x)}, fill_timestamp=0.0).tobytes())


class _Acks:
    def __init__(self):
        self.got: list[tuple] = []

    def __call__(self, peer, rid, status, a, b, tag):
        self.got.append((peer, rid, status, a, b))


def test_requests_are_answered_at_once_while_the_queue_has_room_and_invalid_ones_name_the_field():
    rq = RequestQueue(_LAYOUT, 4)
    acks = _Acks()
    intake = RequestIntake("arm", rq, acks, FairQueue(2, 8), lambda: None)
    intake.take("a", 1, _record(1.0))
    bad = _LAYOUT.encode({"x": np.zeros(2)}, fill_timestamp=0.0)
    bad["x"][1] = np.nan
    intake.take("a", 2, memoryview(bad.tobytes()))
    intake.take("a", 3, memoryview(b"\0" * 3))
    assert acks.got[0] == ("a", 1, m.OK, 3, None)  # OK carries the free slots left (for credits)
    assert acks.got[1][:4] == ("a", 2, m.INVALID, "x") and "NaN" in acks.got[1][4]
    assert acks.got[2][2] == m.INVALID and "3 bytes" in acks.got[2][4]
    assert len(rq) == 1 and rq.rejected == 2
    assert m.ack_error("arm", [1, m.OK, 3, None]) is None
    err = m.ack_error("arm", [2, m.INVALID, "x", "contains NaN or inf"])
    assert isinstance(err, InvalidRequest) and err.node == "arm" and err.field == "x"
    err = m.ack_error("arm", [3, m.FULL, 4, 1.0])
    assert isinstance(err, QueueFull) and "arm" in str(err)


def test_a_full_queue_is_shared_round_robin_and_a_flooder_hears_full():
    """A flooder keeps the node's queue full; an honest peer's request takes the next free slot anyway,
    the flooder's beyond its bound hear FULL at once, and a request that waits past put_timeout hears FULL."""
    rq = RequestQueue(_LAYOUT, 2, put_timeout=0.3)
    acks = _Acks()
    intake = RequestIntake("arm", rq, acks, FairQueue(2, 8), lambda: None)
    for i in range(6):
        intake.take("flood", i, _record(float(i)))
    assert [a[2] for a in acks.got] == [m.OK, m.OK, m.FULL, m.FULL]  # 2 queued, 2 wait, 2 refused at once
    intake.take("honest", 100, _record(100.0))
    rq.get_all()  # the node makes room for two
    intake.feed()
    assert [(a[0], a[1], a[2]) for a in acks.got[4:]] == [("flood", 2, m.OK), ("honest", 100, m.OK)]
    assert [r["x"][0] for r in rq.get_all()] == [2.0, 100.0]
    intake.feed()
    assert acks.got[-1][:3] == ("flood", 3, m.OK)
    intake.take("flood", 7, _record(7.0))
    intake.take("flood", 8, _record(8.0))  # the queue is full again (3 and 7): this one waits
    time.sleep(0.35)
    intake.feed()
    assert acks.got[-1][:3] == ("flood", 8, m.FULL) and acks.got[-1][3:] == (2, 0.3)


# -- both ends, joined in memory -------------------------------------------------------------------------
class _Server(NetworkServer):
    mw = "memory"

    def __init__(self, node, config):
        super().__init__(node, NodeLayouts.of(node), config)
        self.clients: list[_Client] = []

    def _open(self):
        return {"memory": id(self)}

    def _send(self, peer, kind, body, tag=None):
        peer.inbox[kind].put(bytes(body))

    def _broadcast(self, head, record):
        for c in list(self.clients):
            if not c.deaf:
                c._on_stream(head, record)


class _Client(NetworkClient):
    mw = "memory"

    def __init__(self, node, server: _Server, config, hello: bytes | None = None):
        super().__init__(node, NodeLayouts.of(node), {}, config)
        self.server, self.deaf = server, False
        self.inbox = {k: queue.SimpleQueue() for k in (m.HELLO, m.ACK, m.REPLY)}
        server.clients.append(self)
        server.on_message(self, m.HELLO, b"")
        self._handshake(hello or self.inbox[m.HELLO].get(timeout=5), "memory")

    def _send(self, kind, body):
        self.server.on_message(self, kind, bytes(body))

    def _recv(self, kind):
        try:
            return self.inbox[kind].get(timeout=0.05)
        except queue.Empty:
            return None

    def _recv_now(self, kind):
        try:
            return self.inbox[kind].get_nowait()
        except queue.Empty:
            return None


class _Slow(rio.Node):
    def setup(self):
        self.example_data = {"n": 0}
        self.example_request = {"x": np.zeros(2)}
        self.runs = 0

    @remote
    def bump(self):
        self.runs += 1
        return self.runs

    @remote
    def sleep(self, seconds):
        time.sleep(seconds)
        return seconds


def _arm(cls=None) -> rio.Node:
    node = (cls or _Slow)()
    node.name = "arm"
    return node


@pytest.fixture
def pair():
    node = _arm()
    server = _Server(node, NetworkConfig(call_timeout=1.0, heartbeat_s=0.02, heartbeat_timeout=0.3))
    server.start(Dispatcher(node, threading.RLock()))
    made = []

    def client(**config):
        c = _Client(_arm(), server, NetworkConfig(call_timeout=0.5, **config))
        made.append(c)
        return c

    try:
        yield node, server, client
    finally:
        for c in made:
            c.close()
        server.close()


def test_the_mirror_never_goes_backwards_nor_repeats_and_another_epoch_is_a_restart(pair):
    _, server, client = pair
    server.ring_buffer.put({"n": 1})
    c = client()
    assert c.ring_buffer.count == 1 and c.ring_buffer.get()["n"] == 1  # seeded by the handshake
    head = m.STREAM_HEAD.pack(m.STATE, server._fp, server._epoch, 1)
    c._on_stream(head, server._last[1])  # the sample the handshake carried: not twice
    assert c.ring_buffer.count == 1
    for n in (2, 3):
        server.ring_buffer.put({"n": n})
    old = m.STREAM_HEAD.pack(m.STATE, server._fp, server._epoch, 2)
    c._on_stream(old, _Slow().layouts()[0].encode({"n": 99}, fill_timestamp=0.0).tobytes())  # out of order
    assert c.ring_buffer.count == 3 and list(c.ring_buffer.get_last_k(3)["n"]) == [1, 2, 3]
    c._on_stream(m.STREAM_HEAD.pack(m.BEAT, server._fp, server._epoch ^ 1, 0), None)
    with pytest.raises(NodeDiedError, match="'arm'.*restarted"):
        c.check_alive()


def test_silence_is_death_by_name_until_the_server_speaks_again_and_bye_is_final(pair):
    _, server, client = pair
    c = client(heartbeat_timeout=0.3)
    time.sleep(0.4)
    c.check_alive()  # heartbeats every 20 ms
    c.deaf = True
    t0 = time.monotonic()
    assert wait_until(lambda: _dead(c), timeout=2.0)
    assert time.monotonic() - t0 < 1.0
    with pytest.raises(NodeDiedError, match="'arm'.*no heartbeat"):
        c.check_alive()
    c.deaf = False
    assert wait_until(lambda: not _dead(c), timeout=2.0)  # the same server (same epoch): alive again
    server.close()
    with pytest.raises(NodeDiedError, match="'arm'.*server closed"):
        c.check_alive()


def _dead(c) -> bool:
    try:
        c.check_alive()
        return False
    except NodeDiedError:
        return True


def test_calls_late_replies_are_dropped_and_stale_calls_not_run(pair):
    node, server, client = pair
    a, b = client(), client()
    assert a.call("bump", (), {}) == 1
    blocker = threading.Thread(target=lambda: _swallow(lambda: a.call("sleep", (1.3,), {})))
    blocker.start()
    time.sleep(0.05)
    with pytest.raises(NodeTimeout, match="'arm'"):
        b.call("bump", (), {})  # queued behind 1.3 s; its caller gives up after 0.5 s, the node after 1 s ...
    blocker.join(5)
    assert wait_until(lambda: not len(server._calls), timeout=5)
    time.sleep(0.1)
    assert node.runs == 1  # ... and it is not run late
    assert b.call("bump", (), {}) == 2  # its "not run" answer is not taken for this call's
    with pytest.raises(NodeError, match="'arm'.*AttributeError"):
        b.call("nothing", (), {})


def _swallow(fn):
    try:
        fn()
    except rio.RioError:
        pass


def test_too_many_calls_name_the_node(pair):
    _, server, client = pair
    c = client()
    server.on_message("flooder", m.CALL, wire.pack_call(1, "sleep", [0.3], {}))
    time.sleep(0.05)  # running: the rest wait
    for i in range(2, 2 + server.config.max_pending_per_peer + 1):
        server.on_message(c, m.CALL, wire.pack_call(i, "bump", [], {}))
    cid, ok, value = wire.unpack_reply(c.inbox[m.REPLY].get(timeout=5))
    assert not ok and value[0] == "TooManyCalls" and cid == 2 + server.config.max_pending_per_peer


def _req(server, x: float = 1.0) -> bytes:
    return server.request_queue.layout.encode({"x": np.full(2, x)}, fill_timestamp=0.0).tobytes()


def test_requests_through_the_flow(pair):
    _, server, client = pair
    c = client()
    c._send_request(_req(server))
    assert len(server.request_queue) == 1
    c._send_request(b"\0" * 5)  # sent: the node's own check refuses it, and says so in its acknowledgement
    with pytest.raises(InvalidRequest, match="'arm'.*5 bytes") as ei:
        c._send_request(_req(server, 2.0))  # the refusal is raised by the next send, which is not sent
    assert "not sent" in "".join(getattr(ei.value, "__notes__", ["not sent"]))
    assert len(server.request_queue) == 1
    stats = c.request_stats()
    assert (stats.sent, stats.acknowledged, stats.refused_invalid, stats.refused) == (2, 2, 1, 1)
    c._send_request(_req(server, 3.0))  # reported once: the next one goes
    assert len(server.request_queue) == 2


class _Spying(_Client):
    """Keeps what `send_request` hands the transport."""

    def __init__(self, *a, **kw):
        self.handed = []
        super().__init__(*a, **kw)

    def _send_parts(self, kind, *parts):
        self.handed.append((kind, parts))
        super()._send_parts(kind, *parts)


def test_a_request_reaches_the_transport_as_its_record_s_own_memory_joined_once_with_its_id(pair):
    """A request record can be megabytes (an observation with its camera frames): `send_request` hands the
    transport the checked record itself, not a bytes copy of it, with the request's id beside it; the default
    `_send_parts` joins the two once, and the node takes the exact record."""
    _, server, _ = pair
    c = _Spying(_arm(), server, NetworkConfig(call_timeout=0.5))
    try:
        c.request_queue.put({"x": np.array([1.5, -2.5])})
        c.request_queue.put({"x": np.array([3.0, 4.0])})
        (k1, (id1, rec1)), (k2, (id2, rec2)) = c.handed
        assert (k1, k2) == (m.REQUEST, m.REQUEST) and (id1, id2) == (m.REQUEST_ID.pack(1), m.REQUEST_ID.pack(2))
        layout = server.request_queue.layout
        assert isinstance(rec1, np.ndarray) and rec1.dtype == np.uint8 and rec1.nbytes == layout.itemsize
        assert not np.shares_memory(rec1, rec2)  # each request its own record: none is rewritten while in flight
        got = [server.request_queue.get(), server.request_queue.get()]
        assert [list(r["x"]) for r in got] == [[1.5, -2.5], [3.0, 4.0]]
        assert c.request_stats().acknowledged == 2
    finally:
        c.close()


def test_no_credits_fails_at_once_and_acknowledgements_give_credits_back(pair):
    """The node takes nothing (no loop runs it here): its queue fills, then the fair queue's room for this
    peer; with every credit in flight the next request fails at once, sending nothing. Once the node takes
    its queue the waiting ones are acknowledged and the credits come back."""
    _, server, client = pair
    q, credits = server.request_queue, server.config.max_pending_per_peer
    c = client()
    assert c._requests.credits == credits  # granted by the handshake
    for i in range(q.capacity):
        c._send_request(_req(server, i))  # each acknowledged at once: the queue has room
    c.request_stats()  # takes in the acknowledgements that arrived
    assert len(q) == q.capacity and c._requests.available == credits
    for i in range(credits):
        c._send_request(_req(server, 100 + i))  # parked by the server, unacknowledged: credits spent
    assert len(server._intake._waiting) == credits and c._requests.available == 0
    with pytest.raises(QueueFull, match="'arm'.*credits") as ei:
        c._send_request(_req(server, -1))
    assert isinstance(ei.value, NoCredits)
    assert len(server._intake._waiting) == credits  # nothing was sent
    assert c.request_stats().no_credits == 1
    q.get_all()  # the node makes room: the waiting requests go in and are acknowledged
    assert wait_until(lambda: c.request_stats().acknowledged == q.capacity + credits, timeout=5)
    assert c._requests.available == credits
    c._send_request(_req(server, 7.0))
    assert [r["x"][0] for r in q.get_all()] == [100.0 + i for i in range(credits)] + [7.0]


def test_a_request_refused_for_a_full_queue_is_reported_by_the_next_send(pair):
    """A request that waited its queue's put timeout (1 s) for room is refused (FULL): the client hears it
    on its next send as QueueFull naming the node (not NoCredits), and it is counted."""
    _, server, client = pair
    q = server.request_queue
    c = client()
    for i in range(q.capacity + 1):
        c._send_request(_req(server, i))
    c.request_stats()
    assert c._requests.available == server.config.max_pending_per_peer - 1
    assert wait_until(lambda: c.request_stats().refused_full == 1, timeout=5)
    with pytest.raises(QueueFull, match="'arm'.*queue full") as ei:
        c._send_request(_req(server))
    assert not isinstance(ei.value, NoCredits)
    stats = c.request_stats()
    assert (stats.sent, stats.acknowledged, stats.refused) == (q.capacity + 1, q.capacity + 1, 1)


def test_a_client_of_another_layout_or_version_is_refused_by_name(pair):
    node, server, _ = pair
    with pytest.raises(ConfigError, match="'arm'.*layout mismatch"):
        _Client(_arm(EchoNode), server, NetworkConfig())
    with pytest.raises(ConfigError, match="'arm'.*protocol 1"):
        _Client(_arm(), server, NetworkConfig(), hello=wire.pack({"protocol": 1}))


def test_a_renamed_field_still_works_for_one_release():
    with pytest.warns(FutureWarning, match="max_pending_per_connection.*max_pending_per_peer"):
        config = NetworkConfig(max_pending_per_connection=3)
    assert config.max_pending_per_peer == 3 and "max_pending_per_connection" not in config.model_dump()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        NetworkConfig(max_pending_per_peer=3)
