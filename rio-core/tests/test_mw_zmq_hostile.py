"""The zmq middleware against hostile or mistaken peers: oversized messages, floods of calls, slow
calls, unauthenticated and unknown clients, error replies that would leak server paths, and a full
request queue. Each test's docstring names the attack it models. Servers run in their own process
(`ServerManager`, keys travel in the middleware's config) unless the test needs a node defined here."""

from __future__ import annotations

import shutil
import threading
import time
from typing import Any

import numpy as np
import pytest
import zmq
import zmq.utils.monitor

import rio
import rio.machine.keys
from rio import ServerManager, connect, serve
from rio.conformance.middleware import send_in_turn
from rio.errors import ConfigError
from rio.middleware.protocol.messages import REQUEST, REQUEST_ID
from rio.middleware.zmq import ZmqMiddleware
from rio.runtime import wire
from rio.runtime.node import remote
from rio.runtime.runner import Dispatcher
from rio.runtime.transport import NodeLayouts
from rio.testing import EchoNode, wait_until


# -- helpers -------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def keys(tmp_path_factory):
    """A station's keys: `robot` serves the nodes, `laptop` is the operator's machine."""
    root = tmp_path_factory.mktemp("keys")
    rio.machine.keys.generate(root / "st", ["robot", "laptop"])
    return root / "st"


@pytest.fixture(scope="module")
def plain_server():
    with ServerManager("zmq", [serve(EchoNode, name="hostile-plain")]) as mgr:
        yield mgr


@pytest.fixture(scope="module")
def keyed_server(keys):
    with ServerManager("zmq", [serve(EchoNode, name="hostile-keyed")], mw_options={"keys": str(keys / "robot")}) as mgr:
        yield mgr


def _laptop(keys) -> ZmqMiddleware:
    return ZmqMiddleware(keys=str(keys / "laptop"))


def _raw(ctx: zmq.Context, kind: int, addr: dict, port: str) -> zmq.Socket:
    """A socket of a peer that speaks the wire protocol by hand (no keys, no checks)."""
    s = ctx.socket(kind)
    s.setsockopt(zmq.LINGER, 0)
    if kind == zmq.SUB:
        s.setsockopt(zmq.SUBSCRIBE, b"")
    s.connect(f"tcp://{addr['host']}:{addr[port]}")
    return s


def _messages(sock: zmq.Socket, seconds: float) -> list[bytes]:
    """Every message `sock` receives within `seconds`."""
    got: list[bytes] = []
    t_end = time.monotonic() + seconds
    while (left := t_end - time.monotonic()) > 0:
        if sock.poll(int(left * 1000) + 1):
            got.append(b"".join(sock.recv_multipart()))
    return got


def _record(**fields) -> bytes:
    layout = NodeLayouts.of(EchoNode()).request
    return layout.encode({"q": np.zeros(6), "client": 0, "seq": 0, **fields}, fill_timestamp=0.0).tobytes()


def _in_process_server(node: rio.Node, mw: ZmqMiddleware):
    """A server in this process without a node loop: nothing consumes its requests."""
    srv = mw.make_server(node, NodeLayouts.of(node), {})
    addr = srv.start(Dispatcher(node, threading.RLock()))
    if srv.ring_buffer is not None:
        srv.ring_buffer.put(node.read_state())
    return srv, addr


# -- oversized messages, floods, slow calls ---------------------------------------------------------------
def test_oversized_message_disconnects_its_sender_and_the_node_keeps_serving(plain_server):
    """Attack: a peer sends one message larger than `max_message_bytes` (to make the node allocate or
    decode it). The node drops the connection on the message's header, never answers it, and a real
    client is served before and after."""
    addr = plain_server.address("hostile-plain")
    with connect(EchoNode, "zmq", name="hostile-plain") as client:
        assert client.echo(1) == 1
        ctx = zmq.Context()
        try:
            bad = _raw(ctx, zmq.DEALER, addr, "rpc_port")
            monitor = bad.get_monitor_socket(zmq.EVENT_CONNECTED | zmq.EVENT_DISCONNECTED)
            big = (4 << 20) + 1024  # over the default max_message_bytes (4 MiB; EchoNode's requests are small)
            bad.send(b"c" + wire.pack_call(1, "echo", [bytes(big)], {}))
            events = []
            t_end = time.monotonic() + 10.0
            while zmq.EVENT_DISCONNECTED not in events and time.monotonic() < t_end:
                if monitor.poll(100):
                    events.append(zmq.utils.monitor.recv_monitor_message(monitor)["event"])
            assert zmq.EVENT_DISCONNECTED in events, events
            assert _messages(bad, 1.0) == []  # no answer: the message was never read
            assert client.echo(2) == 2
            client.send_request(q=np.zeros(6), client=5, seq=1)
            assert wait_until(lambda: [5, 1] in client.handled(), timeout=5.0)
            bad.disable_monitor()
            monitor.close()
            bad.close()
        finally:
            ctx.destroy(linger=0)


def test_a_flood_of_calls_from_one_stranger_does_not_stop_a_real_client(plain_server):
    """Attack: one peer (one zmq identity) sends 10,000 slow API calls as fast as it can, to fill the
    node's call queue (and its memory) and starve everyone else. The node queues at most a few of them
    and refuses the rest at once ("too many calls queued"); a real client's calls and requests go through
    meanwhile."""
    addr = plain_server.address("hostile-plain")
    ctx = zmq.Context()
    try:
        stranger = ctx.socket(zmq.DEALER)
        stranger.setsockopt(zmq.LINGER, 0)
        stranger.setsockopt(zmq.SNDHWM, 0)  # queue the whole flood here: zmq pushes it as fast as TCP goes
        stranger.connect(f"tcp://{addr['host']}:{addr['rpc_port']}")
        flood = [b"c" + wire.pack_call(i, "sleep", [0.01], {}) for i in range(1, 10_001)]
        for msg in flood:
            stranger.send(msg)
        with connect(EchoNode, ZmqMiddleware(call_timeout=30.0), name="hostile-plain") as client:
            for i in range(20):
                assert client.echo(i) == i
                send_in_turn(client, q=np.full(6, float(i)), client=6, seq=i)
            assert wait_until(lambda: [6, 19] in client.handled(), timeout=30.0)
        replies = [wire.unpack_reply(m[1:]) for m in _messages(stranger, 2.0)]
        refused = [r for r in replies if not r[1] and r[2][0] == "TooManyCalls"]
        assert refused and "too many calls queued" in refused[0][2][1]
        stranger.close()
    finally:
        ctx.destroy(linger=0)


def test_a_slow_call_does_not_delay_other_clients_requests_reads_or_handshakes(plain_server):
    """Attack (or accident): one client's API call takes seconds. Another client's requests are still
    answered, its reads still work, and a new client can still connect, all while that call runs."""
    slow_s = 4.0
    with connect(EchoNode, "zmq", name="hostile-plain") as slow, \
            connect(EchoNode, "zmq", name="hostile-plain") as other:
        done: list[float] = []
        t = threading.Thread(target=lambda: done.append(slow.sleep(slow_s)))
        t.start()
        time.sleep(0.3)  # the call is running now
        for i in range(10):
            send_in_turn(other, 5.0, q=np.zeros(6), client=8, seq=i)  # each acknowledged in time
        assert other.get_state()["tick"] >= 1
        with connect(EchoNode, "zmq", name="hostile-plain") as late:  # a handshake
            assert late.get_state()["tick"] >= 1
        still_running = t.is_alive()
        t.join(slow_s + 20.0)
        assert still_running, "requests, reads and a handshake waited for another client's slow call"
        assert done == [slow_s]
        assert wait_until(lambda: [8, 9] in other.handled(), timeout=5.0)


# -- authentication ------------------------------------------------------------------------------------------
def test_an_unauthenticated_client_gets_nothing_from_a_keyed_node(keys, keyed_server):
    """Attack: a peer without the station's keys reaches a keyed node's ports (the robot's network is
    not private) and reads its state, sends it requests and calls its API. It gets no state, no answer,
    and its request never reaches the node; `rio.connect` without keys says "authentication"."""
    addr = keyed_server.address("hostile-keyed")
    assert addr["identity"] == "robot"
    with pytest.raises(ConfigError, match="hostile-keyed.*authentication"):
        connect(EchoNode, "zmq", name="hostile-keyed")
    # An address without "identity" (written by hand, or forged): the handshake itself fails, at once.
    plain = {k: v for k, v in addr.items() if k != "identity"}
    with pytest.raises(ConfigError, match="hostile-keyed.*authentication"):
        connect(EchoNode, "zmq", name="hostile-keyed", address=plain)
    ctx = zmq.Context()
    try:
        sub = _raw(ctx, zmq.SUB, addr, "state_port")
        dealer = _raw(ctx, zmq.DEALER, addr, "rpc_port")
        dealer.send(b"h")
        dealer.send(b"c" + wire.pack_call(1, "echo", ["hi"], {}))
        dealer.send(REQUEST + REQUEST_ID.pack(1) + _record(client=99, seq=1))
        assert _messages(dealer, 1.5) == []
        assert _messages(sub, 0.5) == []  # the node publishes at 200 Hz: a reader would have had ~100
        sub.close()
        dealer.close()
    finally:
        ctx.destroy(linger=0)
    with connect(EchoNode, _laptop(keys), name="hostile-keyed") as client:
        assert [99, 1] not in client.handled()


def test_a_client_whose_key_the_node_does_not_know_is_refused(keys, keyed_server, tmp_path):
    """Attack: a peer with keys of its own (made with `rio keys generate`, not the station's) and the
    robot's public key (public keys are not secret) tries to connect. The node's ZAP handler refuses its
    key, and the client says "authentication" at once instead of hanging. A client whose copy of the
    robot's key is wrong (another station's robot) fails the same way."""
    rio.machine.keys.generate(tmp_path / "thief", ["intruder"])
    intruder = tmp_path / "thief" / "intruder"
    shutil.copy(keys / "robot" / "peers" / "robot.key", intruder / "peers" / "robot.key")
    with pytest.raises(ConfigError, match="hostile-keyed.*authentication.*refused"):
        connect(EchoNode, ZmqMiddleware(keys=str(intruder)), name="hostile-keyed",
                address=keyed_server.address("hostile-keyed"))
    rio.machine.keys.generate(tmp_path / "other", ["robot", "laptop"])
    with pytest.raises(ConfigError, match="hostile-keyed.*authentication"):
        connect(EchoNode, ZmqMiddleware(keys=str(tmp_path / "other" / "laptop")), name="hostile-keyed",
                address=keyed_server.address("hostile-keyed"))


def test_a_keyed_client_and_node_work_end_to_end(keys, keyed_server):
    """The positive case: with the station's keys on both sides (served in its own process, the keys
    travelling in the middleware config), state streams, requests arrive and calls answer."""
    assert keyed_server.address("hostile-keyed")["identity"] == "robot"
    with connect(EchoNode, _laptop(keys), name="hostile-keyed") as c:
        first = c.get_state()["tick"]
        assert wait_until(lambda: c.get_state()["tick"] >= first + 5, timeout=5.0)
        for i in range(5):
            send_in_turn(c, q=np.full(6, float(i)), client=3, seq=i)
        assert wait_until(lambda: [3, 4] in c.handled(), timeout=5.0)
        assert wait_until(lambda: c.get_state()["last"][0] == 4.0, timeout=5.0)
        np.testing.assert_array_equal(c.echo(np.arange(4.0)), np.arange(4.0))
        with pytest.raises(rio.NodeError, match="boom"):
            c.fail("boom")


# -- what replies say -------------------------------------------------------------------------------------
class _Leaky(rio.Node):
    def setup(self) -> None:
        self.example_request = {"cmd": np.zeros(3)}

    @remote
    def load(self) -> None:
        raise FileNotFoundError("/some/server/path/x.yaml")


def test_error_replies_carry_no_server_paths():
    """Attack: a peer calls methods that fail to map the server's disk (paths in messages, file names
    in tracebacks). It learns the exception's type and message, paths cut to their last part, and no
    traceback."""
    node = _Leaky()
    mw = ZmqMiddleware()
    srv, addr = _in_process_server(node, mw)
    try:
        with connect(_Leaky, mw, name=node.name, address=addr) as c:
            with pytest.raises(rio.NodeError) as ei:
                c.load()
            err = ei.value
            assert err.exc_type == "FileNotFoundError" and "x.yaml" in err.message
            assert "/some/server" not in str(err) and err.remote_traceback == ""
            assert __file__ not in str(err) and "test_mw_zmq_hostile" not in str(err)
    finally:
        srv.close()


def test_a_full_request_queue_makes_send_request_raise_queue_full():
    """Attack (or a stalled node): requests pile up faster than the node takes them. Once its queue is
    full and the requests the server holds for this client have used its credits, `send_request` raises
    QueueFull (NoCredits) naming the node at once, sending nothing, instead of the request being dropped
    with only a line in the server's log; once the node takes its queue the credits come back."""
    node = EchoNode()
    node.name = "stalled"
    mw = ZmqMiddleware()
    srv, addr = _in_process_server(node, mw)  # no node loop: nothing takes the requests
    try:
        with connect(EchoNode, mw, name="stalled", address=addr) as c:
            held = mw.config.max_pending_per_peer  # the credits: requests the server holds for us
            for i in range(node.request_capacity + held):
                send_in_turn(c, q=np.zeros(6), client=1, seq=i)
            with pytest.raises(rio.QueueFull, match="stalled.*credits"):
                c.send_request(q=np.zeros(6), client=1, seq=999)
            assert len(srv.request_queue.get_all()) == node.request_capacity
            send_in_turn(c, q=np.zeros(6), client=1, seq=1000)  # room again: the held ones go in, credits return
            assert wait_until(lambda: len(srv.request_queue) == held + 1, timeout=5.0)
            seqs = [int(r["seq"]) for r in srv.request_queue.get_all()]
            assert seqs == list(range(node.request_capacity, node.request_capacity + held)) + [1000]
    finally:
        srv.close()


class _Counter(rio.Node):
    """Counts the calls it runs; one call can be made slow."""

    def setup(self) -> None:
        self.runs = 0

    @remote
    def sleep(self, seconds: float) -> None:
        time.sleep(seconds)

    @remote
    def bump(self) -> int:
        self.runs += 1
        return self.runs


def test_calls_whose_callers_gave_up_are_not_run():
    """Attack (or an overloaded node): a slow call holds the API thread while other calls queue behind
    it and their callers time out. Running them afterwards would do work nobody waits for (and, for a
    command, act late); a call that waited past `call_timeout` is skipped."""
    node = _Counter()
    mw = ZmqMiddleware(call_timeout=1.0)
    srv, addr = _in_process_server(node, mw)
    try:
        with connect(_Counter, mw, name=node.name, address=addr) as first, \
                connect(_Counter, mw, name=node.name, address=addr) as second, \
                connect(_Counter, mw, name=node.name, address=addr) as late:
            ended: dict[str, str] = {}

            def call(name: str, client: Any, seconds: float) -> None:
                try:
                    client.sleep(seconds)
                    ended[name] = "returned"
                except rio.NodeTimeout:
                    ended[name] = "timed out"

            calls = [threading.Thread(target=call, args=("first", first, 0.9), daemon=True),
                     threading.Thread(target=call, args=("second", second, 1.5), daemon=True)]
            for c in calls:  # the first holds the API thread, the second queues behind it
                c.start()
                time.sleep(0.15)
            with pytest.raises(rio.NodeTimeout):
                late.bump()  # behind ~0.6 + 1.5 s of calls: its caller gives up after 1 s
            for c in calls:
                c.join(10)
            assert ended.get("second") == "timed out"  # its 1.5 s call outlasts the 1 s call timeout
            time.sleep(1.0)  # whatever was still queued has been run or skipped by now
            assert node.runs == 0
            assert late.bump() == 1  # the node serves fresh calls
    finally:
        srv.close()
