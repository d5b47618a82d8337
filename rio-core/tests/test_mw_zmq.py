"""The zmq middleware end to end: real server processes on tcp loopback, clients in this process."""

from __future__ import annotations

import os
import signal
import socket
import threading
import time

import numpy as np
import pytest
from pydantic import ValidationError

import rio
from rio import ServerManager, connect, serve
from rio.conformance.middleware import send_in_turn
from rio.errors import ConfigError
from rio.middleware.zmq import ZmqMiddleware
from rio.runtime.node import remote
from rio.testing import EchoNode, ImageNode, wait_until


def _remote_view(address: dict) -> dict:
    """The address as a client on another machine sees it: no usable pid, so liveness comes from
    the heartbeat alone."""
    return {k: v for k, v in address.items() if k not in ("pid", "machine")}


@pytest.fixture(scope="module")
def echo_server():
    with ServerManager("zmq", [serve(EchoNode, name="echo")]) as mgr:
        yield mgr


@pytest.fixture
def c(echo_server):
    with connect(EchoNode, "zmq", name="echo") as client:
        yield client


def test_state_seeded_at_connect_then_streams(c):
    first = c.get_state()  # no sleep: the handshake seeded the mirror
    assert first["tick"] >= 1
    assert wait_until(lambda: c.get_state()["tick"] >= first["tick"] + 6, timeout=2.0)
    last5 = c.get_state(k=5)
    assert last5["tick"].shape == (5,) and last5["q"].shape == (5, 6)
    assert np.all(np.diff(last5["tick"]) == 1)  # consecutive: nothing dropped or duplicated
    assert np.all(np.diff(last5["timestamp"]) > 0)
    np.testing.assert_array_equal(last5["q"][-1], np.full(6, float(last5["tick"][-1])))


def test_requests_arrive_in_order(c):
    before = len(c.handled())
    for i in range(20):
        send_in_turn(c, q=np.full(6, float(i)), client=7, seq=i)  # credits: a burst waits for acks
    assert wait_until(lambda: len(c.handled()) >= before + 20, timeout=2.0)
    mine = [tuple(x) for x in c.handled() if x[0] == 7]
    assert mine[-20:] == [(7, i) for i in range(20)]
    assert wait_until(lambda: c.get_state()["last"][0] == 19.0, timeout=2.0)


def test_echo_round_trips(c):
    payload = np.ones(256)  # 2048 bytes
    out = c.echo(payload)
    assert out.dtype == payload.dtype and out.nbytes == 2048
    np.testing.assert_array_equal(out, payload)
    assert c.echo({"a": [1, 2.5, "x"], "b": None}) == {"a": [1, 2.5, "x"], "b": None}
    assert c.pid() == c._transport._watch.pid


def test_remote_exception_names_node(c):
    with pytest.raises(rio.NodeError, match="echo") as ei:
        c.fail("boom")
    assert ei.value.exc_type == "ValueError" and ei.value.message == "boom"
    assert ei.value.remote_traceback == ""  # the traceback stays in the server's (debug) log
    with pytest.raises(rio.NodeError, match="AttributeError"):
        c._transport.call("no_such_method", (), {})
    assert c.echo(3) == 3  # still serving


def test_invalid_requests_rejected_node_keeps_serving(c):
    with pytest.raises(rio.InvalidRequest, match="NaN"):
        c.send_request(q=np.full(6, np.nan), client=1, seq=0)
    with pytest.raises(rio.InvalidRequest, match="shape"):
        c.send_request(q=np.zeros(5), client=1, seq=0)
    # A peer that skips client-side validation: the server re-checks, refuses and says so.
    rec = c._node.request_queue._obj.layout.encode({"q": np.zeros(6), "client": 2, "seq": 0}, fill_timestamp=0.0)
    rec["q"][0] = np.inf
    with pytest.raises(rio.InvalidRequest, match="echo.*q"):
        c._transport.send_request_acknowledged(rec.tobytes())
    with pytest.raises(rio.InvalidRequest, match="echo.*3 bytes"):
        c._transport.send_request_acknowledged(b"\x00" * 3)  # wrong size
    c.send_request(q=np.zeros(6), client=2, seq=1)
    assert wait_until(lambda: [2, 1] in c.handled(), timeout=2.0)
    assert [2, 0] not in c.handled()
    assert c.echo("alive") == "alive"


def test_layout_mismatch_is_config_error(echo_server):
    with pytest.raises(ConfigError, match="echo"):
        connect(EchoNode, "zmq", name="echo", n=3, address=echo_server.address("echo"))


def test_call_timeout_then_recovers(echo_server):
    mw = ZmqMiddleware(call_timeout=0.2)
    with connect(EchoNode, mw, name="echo") as c:
        with pytest.raises(rio.NodeTimeout, match="echo"):
            c.sleep(0.5)
        time.sleep(0.4)  # calls run one at a time: let `sleep` finish
        assert c.echo(5) == 5  # the late reply of `sleep` is recognized as stale and dropped


def test_options_validated():
    with pytest.raises(ValidationError):
        ZmqMiddleware(bogus=1)
    with pytest.raises(ValidationError):
        ZmqMiddleware(state_port=70000)
    assert ZmqMiddleware().config.host == "127.0.0.1"


def test_sigkill_reported_within_a_second():
    with ServerManager("zmq", [serve(EchoNode, name="victim")]) as mgr:
        addr = mgr.address("victim")
        local = connect(EchoNode, "zmq", name="victim")
        remote = connect(EchoNode, "zmq", name="victim", address=_remote_view(addr))
        try:
            assert local.get_state()["tick"] >= 1 and remote.get_state()["tick"] >= 1
            assert remote._transport._watch is None  # heartbeat-only liveness
            time.sleep(0.3)
            remote.get_state()  # heartbeats keep it alive while the server runs

            in_flight: list[BaseException] = []

            def long_call() -> None:
                try:
                    local.sleep(30.0)
                except BaseException as e:
                    in_flight.append(e)

            t = threading.Thread(target=long_call)
            t.start()
            time.sleep(0.1)
            os.kill(mgr.pids()["victim"], signal.SIGKILL)
            t0 = time.monotonic()
            for client in (local, remote):
                assert wait_until(lambda cl=client: _raises_died(cl.get_state),
                                  timeout=1.0 - (time.monotonic() - t0))
            assert time.monotonic() - t0 < 1.0
            t.join(1.0)
            assert not t.is_alive() and isinstance(in_flight[0], rio.NodeDiedError)
            with pytest.raises(rio.NodeDiedError, match="victim"):
                local.echo(1)
            with pytest.raises(rio.NodeDiedError, match="victim"):
                remote.send_request(q=np.zeros(6), client=0, seq=0)
        finally:
            local.close()
            remote.close()


def _raises_died(fn) -> bool:
    try:
        fn()
    except rio.NodeDiedError:
        return True
    return False


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_image_stream_fixed_ports_and_clean_shutdown():
    ports = {"state_port": _free_port(), "rpc_port": _free_port()}
    with ServerManager("zmq", [serve(ImageNode, name="cam", rate_hz=30.0)], mw_options=ports) as mgr:
        addr = mgr.address("cam")
        assert (addr["state_port"], addr["rpc_port"]) == (ports["state_port"], ports["rpc_port"])
        c = connect(ImageNode, "zmq", name="cam")
        remote = connect(ImageNode, "zmq", name="cam", address=_remote_view(addr))
        s = c.get_state()
        assert s["rgb"].shape == (480, 640, 3) and s["rgb"].dtype == np.uint8
        f0 = int(s["frame"])
        assert wait_until(lambda: int(c.get_state()["frame"]) >= f0 + 5, timeout=3.0)
        s = c.get_state()
        assert np.all(s["rgb"] == int(s["frame"]) % 4)
        assert int(remote.get_state()["frame"]) >= f0
    # A clean stop says "bye": even a heartbeat-only client knows at once.
    t0 = time.monotonic()
    assert wait_until(lambda: _raises_died(remote.get_state), timeout=0.3)
    assert time.monotonic() - t0 < 0.3
    c.close()
    remote.close()
    assert not [t for t in threading.enumerate() if t.name.startswith("rio-cam-")]  # the clients' threads


def test_restarted_server_is_a_new_server():
    """A server that crashes (no "bye") and comes back on the same ports within the heartbeat
    timeout must not silently feed an old client (its sequence numbers restart, its layout may
    differ): the client reports the node gone and must connect again. In-process servers keep this
    fast."""
    from rio.runtime.runner import Dispatcher
    from rio.runtime.transport import NodeLayouts

    ports = {"state_port": _free_port(), "rpc_port": _free_port()}
    mw = ZmqMiddleware(**ports)

    def start_server():
        node = EchoNode()
        node.name = "phoenix"
        srv = mw.make_server(node, NodeLayouts.of(node), {})
        addr = srv.start(Dispatcher(node, threading.RLock()))
        srv.ring_buffer.put(node.read_state())
        return srv, addr

    a, addr = start_server()
    c = connect(EchoNode, mw, name="phoenix", address=_remote_view(addr))
    try:
        assert c.get_state()["tick"] == 1 and c.echo(2) == 2
        a._send_control = lambda kind: None  # crash: no "bye"
        a.close()
        b, _ = start_server()
        try:
            assert wait_until(lambda: _raises_died(c.get_state), timeout=0.4)
            with pytest.raises(rio.NodeDiedError, match="phoenix.*restarted"):
                c.echo(1)
            with connect(EchoNode, mw, name="phoenix", address=_remote_view(addr)) as fresh:
                assert fresh.echo(3) == 3
        finally:
            b.close()
    finally:
        c.close()


class _ReqOnly(rio.Node):
    def setup(self) -> None:
        self.example_request = {"cmd": np.zeros(3)}

    @remote
    def ping(self) -> str:
        return "pong"


def test_node_without_state_in_process_server():
    """No example_data: no ring buffer on either side, but requests, calls and liveness work."""
    from rio.runtime.runner import Dispatcher
    from rio.runtime.transport import NodeLayouts

    node = _ReqOnly()
    mw = ZmqMiddleware()
    srv = mw.make_server(node, NodeLayouts.of(node), {})
    assert srv.ring_buffer is None
    addr = srv.start(Dispatcher(node, threading.RLock()))
    try:
        with connect(_ReqOnly, mw, name=node.name, address=_remote_view(addr)) as c:
            assert c.ping() == "pong"
            c.send_request(cmd=np.arange(3.0))
            assert wait_until(lambda: len(srv.request_queue) == 1, timeout=2.0)
            np.testing.assert_array_equal(srv.request_queue.get()["cmd"], np.arange(3.0))
            time.sleep(0.3)
            c.check_alive()  # heartbeats alone keep a state-less node alive
    finally:
        srv.close()


class _Frames(rio.Node):
    request_capacity = 8

    def setup(self) -> None:
        self.example_request = {"rgb": np.zeros((480, 640, 3), np.uint8), "k": 0}


def test_frame_sized_requests_arrive_exact_and_looking_for_acknowledgements_finds_none_quietly():
    """Requests of a 640x480 frame (over pyzmq's 64 kB copy threshold: joined once and handed to libzmq without
    a copy of its own), sent back to back, each arrive bit for bit; looking for acknowledgements when none has
    come (every send does) answers None."""
    from rio.middleware.protocol.messages import ACK
    from rio.runtime.runner import Dispatcher
    from rio.runtime.transport import NodeLayouts

    node = _Frames()
    mw = ZmqMiddleware()
    srv = mw.make_server(node, NodeLayouts.of(node), {})
    addr = srv.start(Dispatcher(node, threading.RLock()))
    try:
        with connect(_Frames, mw, name=node.name, address=_remote_view(addr)) as c:
            t = c._transport
            assert t._recv_now(ACK) is None
            frames = [np.random.default_rng(k).integers(0, 256, (480, 640, 3), dtype=np.uint8) for k in range(4)]
            for k, f in enumerate(frames):
                c.send_request(rgb=f, k=k)
            assert wait_until(lambda: len(srv.request_queue) == 4, timeout=5.0)
            for k, f in enumerate(frames):
                got = srv.request_queue.get()
                assert got["k"] == k and np.array_equal(got["rgb"], f)
            assert t.request_stats(wait_s=2.0).acknowledged == 4
            assert t._recv_now(ACK) is None
    finally:
        srv.close()


def _peak_rss(pid: int) -> int:
    """The process's peak resident memory so far (VmHWM), bytes."""
    for line in open(f"/proc/{pid}/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024
    raise AssertionError("no VmHWM")


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="peak memory is read from /proc (Linux)")
def test_a_peer_claiming_a_huge_message_is_disconnected_before_the_node_allocates_it():
    """A hostile peer on the rpc port: one 300 MB message (the probe saw a node grow from 52 to 352 MB) is
    refused by its header, the node's peak memory does not grow by it, and real clients are served throughout."""
    import zmq

    with ServerManager("zmq", [serve(EchoNode, name="victim")]) as mgr:
        addr = mgr.address("victim")
        pid = int(addr["pid"])
        with connect(EchoNode, "zmq", name="victim") as client:
            assert client.echo(1) == 1
            peak0 = _peak_rss(pid)
            ctx = zmq.Context()
            bad = ctx.socket(zmq.DEALER)
            bad.setsockopt(zmq.LINGER, 0)
            bad.connect(f"tcp://{addr['host']}:{addr['rpc_port']}")
            bad.send(b"c" + bytes(300 << 20))
            time.sleep(1.5)
            assert client.echo(2) == 2
            assert _peak_rss(pid) - peak0 < 100 << 20
            bad.close()
            ctx.term()


def test_the_message_limit_fits_the_nodes_requests():
    from rio.middleware.zmq import ZmqServer
    from rio.runtime.node import Node

    class Big(Node):
        def setup(self):
            self.example_request = {"img": np.zeros((2000, 1000, 3), np.uint8)}  # 6 MB: over the default 4 MiB

    from rio.runtime.transport import NodeLayouts

    node = Big()
    layouts = NodeLayouts.of(node)
    server = ZmqServer(node, layouts, ZmqMiddleware.Config())
    try:
        assert server.max_message_bytes >= layouts.request.itemsize + 1 > 4 << 20
    finally:
        server.close()
