"""The portal middleware against rio.testing nodes (a spawned server process per node), including
peers that break the protocol on purpose (raw sockets, and danijar's own `portal.Client`)."""

from __future__ import annotations

import multiprocessing
import os
import signal
import socket
import struct
import subprocess
import sys
import textwrap
import threading
import time
from typing import Any

import msgpack
import numpy as np
import pytest

import rio
from rio.conformance.middleware import send_in_turn
from rio.errors import ConfigError
from rio.middleware.portal import PortalMiddleware
from rio.runtime import wire
from rio.runtime.manager import ServerManager, connect, serve
from rio.runtime.transport import NodeLayouts
from rio.testing import EchoNode, ImageNode, freeze_process, wait_until

MW = "portal"


@pytest.fixture(scope="module")
def echo():
    with ServerManager(MW, [serve(EchoNode, name="echo")]) as mgr:
        with connect(EchoNode, MW, name="echo") as c:
            yield mgr, c


def test_address_is_loopback_with_a_picked_port(echo):
    mgr, _ = echo
    addr = mgr.address("echo")
    assert addr["host"] == "127.0.0.1" and addr["port"] > 0 and addr["pid"] == mgr.pids()["echo"]


def test_state_and_last_k(echo):
    _, c = echo
    s = c.get_state()  # seeded by the handshake: readable at once
    assert s["q"].shape == (6,)
    t0 = s["tick"]
    assert wait_until(lambda: c.get_state()["tick"] >= t0 + 5)
    k = c.get_state(k=5)
    assert k["tick"].shape == (5,) and k["q"].shape == (5, 6)
    assert np.all(np.diff(k["tick"]) == 1)  # the mirror holds every sample, in order
    assert np.all(np.diff(k["timestamp"]) > 0)


def test_requests_arrive_in_order(echo):
    _, c = echo
    for i in range(50):
        send_in_turn(c, q=np.full(6, float(i)), client=7, seq=i)  # credits: a burst waits for acks
    assert wait_until(lambda: np.all(c.get_state()["last"] == 49.0))
    assert wait_until(lambda: [h for h in c.handled() if h[0] == 7] == [[7, i] for i in range(50)])


def test_echo_round_trip(echo):
    _, c = echo
    x = np.arange(256, dtype=np.float64)  # 2048 bytes
    y = c.echo(x)
    assert y.dtype == x.dtype and np.array_equal(x, y)
    assert c.echo({"a": [1, "b"], "n": None}) == {"a": [1, "b"], "n": None}


def test_remote_error_names_node(echo):
    _, c = echo
    with pytest.raises(rio.NodeError, match="echo") as ei:
        c.fail("x")
    assert ei.value.exc_type == "ValueError" and ei.value.message == "x"
    # Part 7 of "Hardening": a reply that leaves the node carries no traceback (it shows the server's paths).
    assert ei.value.remote_traceback == "" and ".py" not in str(ei.value)
    with pytest.raises(rio.NodeError) as ei:
        c.fail("cannot read /home/robot/secret/calib.yaml")
    assert "calib.yaml" in ei.value.message and "/home/robot" not in str(ei.value)
    assert c.echo(1) == 1  # still serving


def test_invalid_requests_refused_and_node_keeps_serving(echo):
    _, c = echo
    with pytest.raises(rio.InvalidRequest, match="q"):
        c.send_request(q=np.array([np.nan] * 6), client=1, seq=0)
    with pytest.raises(rio.InvalidRequest, match="shape"):
        c.send_request(q=np.zeros(5), client=1, seq=0)
    c.send_request(q=np.full(6, 3.0), client=1, seq=1)
    assert wait_until(lambda: [1, 1] in c.handled())


def test_server_rechecks_raw_records(echo):
    """A record that skipped client-side validation (a foreign client): refused by the server too, and
    the refusal is raised by the sender (not dropped silently, not only logged)."""
    _, c = echo
    rec = EchoNode().layouts()[1].empty()
    rec["q"], rec["client"], rec["seq"] = np.nan, 3, 1
    with pytest.raises(rio.InvalidRequest, match="echo.*NaN") as ei:
        c._transport.send_request_acknowledged(rec.tobytes())
    assert ei.value.field == "q"
    c.send_request(q=np.zeros(6), client=3, seq=2)
    assert wait_until(lambda: [3, 2] in c.handled())
    assert [3, 1] not in c.handled()


def test_layout_mismatch_is_config_error(echo):
    with pytest.raises(ConfigError, match="echo"):
        connect(EchoNode, MW, name="echo", n=7)


def test_sigkill_reported_within_1s():
    with ServerManager(MW, [serve(EchoNode, name="echo")]) as mgr:
        with connect(EchoNode, MW, name="echo") as a, connect(EchoNode, MW, name="echo") as b:
            a.get_state()
            assert b.echo(1) == 1
            os.kill(mgr.pids()["echo"], signal.SIGKILL)
            t0 = time.monotonic()
            for fn in (a.get_state, lambda: b.echo(np.zeros(3))):
                with pytest.raises(rio.NodeDiedError, match="echo"):
                    while time.monotonic() - t0 < 1.0:
                        fn()
                        time.sleep(0.005)
                    pytest.fail("no NodeDiedError within 1 s")
            assert time.monotonic() - t0 < 1.0
            with pytest.raises(rio.NodeDiedError):
                a.send_request(q=np.zeros(6), client=0, seq=0)


def test_heartbeat_detects_silent_remote_server():
    """Address not on this machine (no pid): a stopped server is noticed through the long poll."""
    host = socket.gethostbyname(socket.gethostname())
    with ServerManager(MW, [serve(EchoNode, name="echo")], mw_options={"host": "0.0.0.0", "insecure": True}) as mgr:
        addr = {"host": host, "port": mgr.address("echo")["port"]}
        with connect(EchoNode, PortalMiddleware(), name="echo", address=addr) as c:
            assert c._transport._watch is None  # watched by heartbeat, not by pid
            assert c.echo(5) == 5
            time.sleep(0.3)
            c.get_state()  # heartbeats keep it alive while idle
            pid = mgr.pids()["echo"]
            freeze_process(pid)
            try:
                t0 = time.monotonic()
                with pytest.raises(rio.NodeDiedError, match="heartbeat"):
                    while time.monotonic() - t0 < 1.0:
                        c.get_state()
                        time.sleep(0.01)
                assert time.monotonic() - t0 < 1.0
            finally:
                os.kill(pid, signal.SIGCONT)


def test_fixed_port_option():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with ServerManager(MW, [serve(EchoNode, name="echo", rate_hz=20.0)], mw_options={"port": port}) as mgr:
        assert mgr.address("echo")["port"] == port
        with connect(EchoNode, MW, name="echo") as c:
            assert c.echo(3) == 3


def test_image_stream():
    with ServerManager(MW, [serve(ImageNode, name="cam", rate_hz=30.0)]):
        with connect(ImageNode, MW, name="cam") as cam:
            f0 = cam.get_state()["frame"]
            assert wait_until(lambda: cam.get_state()["frame"] >= f0 + 10, timeout=5.0)
            s = cam.get_state()
            assert s["rgb"].shape == (480, 640, 3) and s["rgb"].dtype == np.uint8
            assert np.all(s["rgb"] == s["frame"] % 4)
    assert not [t.name for t in threading.enumerate() if t.name.startswith("rio-cam-")]  # close() joined its threads


def test_connect_to_nothing_fails_fast():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    t0 = time.monotonic()
    with pytest.raises(rio.NodeDiedError, match="echo"):
        connect(EchoNode, MW, name="echo", address={"host": "127.0.0.1", "port": port})
    assert time.monotonic() - t0 < 2.0


def test_portal_package_is_not_imported():
    """Both ends are ours: serving and calling a node never imports `portal` (whose import would also
    force the spawn start method on the whole program)."""
    code = textwrap.dedent("""
        import multiprocessing as mp, sys
        from rio.runtime.transport import NodeLayouts
        from rio.middleware.portal import PortalMiddleware
        from rio.testing import EchoNode

        node, mw = EchoNode(), PortalMiddleware()
        server = mw.make_server(node, NodeLayouts.of(node), {})
        client = mw.make_client(node, NodeLayouts.of(node), server.start(lambda method, args, kwargs: args[0]))
        assert client.call("echo", (3,), {}) == 3
        client.close()
        server.close()
        print("PORTAL", "portal" in sys.modules, mp.get_start_method(allow_none=True))
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert "PORTAL False None" in out.stdout


# -- hostile peers ------------------------------------------------------------------------------------
# Each test models one attack on a served node with a raw socket speaking (or breaking) portal's wire
# format, built byte by byte here, independently of the code under test; then checks that the node
# survives and keeps serving a well-behaved client.
def _frame(method: bytes, leaf: bytes, specs: Any = (("bytes",),), reqnum: int = 1) -> bytes:
    """One portal request: u64 length, reqnum, name length, name, packlib of the argument tuple."""
    tree, spec = msgpack.packb([None]), msgpack.packb(specs)
    body = (struct.pack("<QQ", reqnum, len(method)) + method
            + struct.pack("<4Q", 3, len(tree), len(spec), len(leaf)) + tree + spec + leaf)
    return struct.pack("<Q", len(body)) + body


def _raw(mgr: ServerManager, handshake: bool = True) -> socket.socket:
    s = socket.create_connection(("127.0.0.1", mgr.address("echo")["port"]), timeout=30)
    if handshake:
        s.sendall(b"portal_handshake")
    return s


def _exact(s: socket.socket, n: int) -> bytes:
    buf = b""
    while len(buf) < n:
        part = s.recv(n - len(buf))
        if not part:
            raise ConnectionError("closed")
        buf += part
    return buf


def _reply(s: socket.socket) -> tuple[int, int, bytes]:
    """(reqnum, status, rest): rest is the error text, or packlib of the result (its leaf: rest[42:])."""
    body = _exact(s, struct.unpack("<Q", _exact(s, 8))[0])
    reqnum, status = struct.unpack_from("<QQ", body)
    return reqnum, status, body[16:]


def _closed_by_server(s: socket.socket) -> bool:
    """True once the server has closed the connection (EOF or reset) without sending anything more."""
    try:
        return s.recv(1) == b""
    except ConnectionResetError:
        return True


def _rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmRSS:")) / 1024


def _serving(c: Any, x: float = 1.5) -> bool:
    tick = c.get_state()["tick"]
    return c.echo(x) == x and wait_until(lambda: c.get_state()["tick"] > tick, timeout=10.0)


def test_zero_length_prefix_drops_only_that_peer(echo):
    """Attack: a length prefix of 0 after the handshake (portal's server asserted, and its loop thread
    then ended the node with os._exit). Refused before reading anything more: that peer is dropped."""
    mgr, c = echo
    with _raw(mgr) as s:
        s.sendall(struct.pack("<Q", 0))
        assert _closed_by_server(s)
    assert _serving(c)


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="reads VmRSS from /proc")
@pytest.mark.parametrize("claim", [2**32, 3 << 30], ids=["4GiB", "3GiB"])
def test_huge_length_claim_allocates_nothing(echo, claim):
    """Attack: a length prefix claiming gigabytes, then data streamed behind it (portal's server allocated
    the claim first and filled it with what arrived: +351 MB RSS for 3 GiB). Refused on the prefix alone:
    the node's memory does not grow and the peer is dropped."""
    mgr, c = echo
    pid = mgr.pids()["echo"]
    before = _rss_mb(pid)
    junk = bytes(1 << 20)
    with _raw(mgr) as s:
        try:
            s.sendall(struct.pack("<QQQ", claim, 1, 4) + b"call")
            for _ in range(96):  # 96 MiB, as long as the server takes it
                s.sendall(junk)
        except OSError:
            pass  # dropped by the server: what should happen
        assert _closed_by_server(s)
    assert _serving(c)
    assert _rss_mb(pid) - before < 50


def test_burst_of_valid_frames(echo):
    """Attack: 10,000 valid calls in one burst from one connection (portal's server queued them all and
    ended the node: "Too many incoming messages enqueued"). At most max_pending_per_connection wait; every
    other one is answered with an error at once; a well-behaved client keeps reading state and calling."""
    mgr, c = echo
    n = 10_000
    burst = b"".join(_frame(b"call", wire.pack_call(i, "echo", [i], {}), reqnum=i) for i in range(n))
    answers: dict[int, int] = {}

    def read_answers() -> None:
        try:
            while len(answers) < n:
                reqnum, status, _ = _reply(s)
                answers[reqnum] = status
        except OSError:
            pass

    with _raw(mgr) as s:
        reader = threading.Thread(target=read_answers, daemon=True)
        reader.start()
        s.sendall(burst)
        assert _serving(c)  # while the burst is being answered
        reader.join(120)
    assert len(answers) == n, f"{n - len(answers)} messages were not answered"
    assert 0 in answers.values()  # some were run; the rest refused, none dropped silently
    assert _serving(c, 2.5)


def test_non_bytes_leaf_attaches_no_shared_memory(echo):
    """Attack: a `sharray` leaf naming someone else's shared-memory segment (portal decoded it by attaching
    the segment, and unlinked it when the array was garbage collected; also any numpy leaf). Refused
    without decoding any leaf: nothing attached, the victim segment survives, the node keeps serving."""
    if not os.path.isdir("/dev/shm"):
        pytest.skip("no /dev/shm")
    mgr, c = echo
    name = f"rio_test_victim_{os.getpid()}"
    path = f"/dev/shm/{name}"
    with open(path, "wb") as f:
        f.write(bytes(64))
    try:
        with _raw(mgr) as s:
            s.sendall(_frame(b"call", b"\0", specs=[["sharray", [8], "<f8", name]], reqnum=7))
            reqnum, status, text = _reply(s)
            assert (reqnum, status != 0) == (7, True), text
            s.sendall(_frame(b"call", np.zeros(4).tobytes(), specs=[["array", [4], "<f8"]], reqnum=8))
            assert _reply(s)[:2] == (8, 2)
        assert _serving(c)
        time.sleep(0.5)  # a decoded SharedArray would be unlinked when collected
        assert os.path.exists(path)
        with open(f"/proc/{mgr.pids()['echo']}/maps") as f:
            assert name not in f.read()
    finally:
        os.unlink(path)


def test_garbage_before_handshake(echo):
    """Attack: a peer that skips the handshake and sends a well-formed call: not answered, dropped."""
    mgr, c = echo
    with _raw(mgr, handshake=False) as s:
        s.sendall(_frame(b"hello", b"\0"))
        assert _closed_by_server(s)
    assert _serving(c)


def test_garbage_after_handshake(echo):
    """Attack: garbage after a good handshake. A well-framed message with a garbage body is answered with
    an error and the connection goes on; bytes that break the framing (here a length prefix of 2**64 - 1,
    which made portal's server end the node) drop the peer."""
    mgr, c = echo
    with _raw(mgr) as s:
        s.sendall(struct.pack("<Q", 40) + bytes(range(200, 240)))
        reqnum, status, _ = _reply(s)
        assert reqnum == int.from_bytes(bytes(range(200, 208)), "little") and status != 0
        s.sendall(_frame(b"hello", b"\0", reqnum=5))
        assert _reply(s)[:2] == (5, 0)  # still in sync
        s.sendall(b"\xff" * 64)
        assert _closed_by_server(s)
    assert _serving(c)


def test_half_frame_stall_blocks_nobody(echo):
    """Attack: a peer announces a 1000-byte message, sends 10 bytes and stalls: it holds up nobody
    (a new client connects and calls, the existing one keeps mirroring)."""
    mgr, c = echo
    with _raw(mgr) as s:
        s.sendall(struct.pack("<Q", 1000) + bytes(10))
        with connect(EchoNode, MW, name="echo", address=mgr.address("echo")) as other:
            assert other.echo(4) == 4
        assert _serving(c)


def test_slow_call_does_not_stop_heartbeats(echo):
    """A slow API call (4 s) must not hold up long polls or requests, of its own connection or another:
    both clients here are watched by heartbeat only (no pid in the address), as on another machine."""
    mgr, _ = echo
    addr = {"host": "127.0.0.1", "port": mgr.address("echo")["port"]}  # no pid: heartbeat only
    mw = PortalMiddleware(heartbeat_timeout=1.5)
    with connect(EchoNode, mw, name="echo", address=addr) as a, connect(EchoNode, mw, name="echo", address=addr) as b:
        assert a._transport._watch is None
        slow = threading.Thread(target=a.sleep, args=(4.0,))
        slow.start()
        i = 0
        while slow.is_alive():
            a.get_state()  # raises NodeDiedError once the heartbeat stops
            b.get_state()
            b.send_request(q=np.full(6, 0.5), client=11, seq=i)  # acknowledged: queued, the call holds the loop
            i += 1
            time.sleep(0.1)  # 40 requests in 4 s: within the node's queue (64), so never out of credits
        slow.join()
        assert i > 0 and _serving(b)


def test_full_request_queue_raises_queue_full(echo):
    """No silent drops: while a slow call holds the node (its loop takes no requests), requests fill the
    node's queue and the next `send_request` raises QueueFull naming the node."""
    _, c = echo
    slow = threading.Thread(target=c.sleep, args=(5.0,))
    slow.start()
    sent = 0
    try:
        time.sleep(0.2)
        with pytest.raises(rio.QueueFull, match="node 'echo': request queue full"):
            for sent in range(500):  # noqa: B007 - counted for the assertion below
                send_in_turn(c, 1.0, q=np.zeros(6), client=12, seq=sent)  # NoCredits for good once it is full
        assert sent >= 64, sent  # the node's queue filled first
    finally:
        slow.join()
    c._transport.request_stats(wait_s=5.0)  # requests held past the put timeout were refused: said once
    with pytest.raises(rio.QueueFull, match="'echo'.*for 1 s"):
        c.send_request(q=np.zeros(6), client=12, seq=998)
    send_in_turn(c, q=np.zeros(6), client=12, seq=999)  # credits back once the node caught up
    assert wait_until(lambda: [12, 999] in c.handled(), timeout=10.0)


def test_calls_of_a_departed_client_are_not_run(echo):
    """Attack: a peer queues slow calls (8 x 2 s) and disconnects. Calls nobody waits for are discarded:
    another client's call runs after at most the one already running (else it would time out)."""
    mgr, c = echo
    with _raw(mgr) as s:
        s.sendall(b"".join(_frame(b"call", wire.pack_call(i, "sleep", [2.0], {}), reqnum=i) for i in range(8)))
        time.sleep(0.3)
    assert c.echo(6) == 6  # within call_timeout (10 s)


@pytest.fixture
def portal_pkg():
    """danijar's portal package (its import forces the spawn start method: put the old one back)."""
    before = multiprocessing.get_start_method(allow_none=True)
    portal = pytest.importorskip("portal")
    multiprocessing.set_start_method(before, force=True)
    return portal


def test_real_portal_client_interoperates(echo, portal_pkg):
    """The real boundary: danijar's `portal.Client` (its own framing code, reqnums from 0) calls hello,
    an API method, and a request on our server; a numpy argument gets an error answer, not silence."""
    mgr, c = echo
    client = portal_pkg.Client(f"127.0.0.1:{mgr.address('echo')['port']}", logging=False)
    try:
        hello = wire.unpack(client.call("hello", b"\0").result(timeout=10))
        assert list(hello["fingerprint"]) == NodeLayouts.of(EchoNode()).fingerprint() and hello["count"] > 0
        ok, value = wire.unpack_reply(client.call("call", wire.pack_call(5, "echo", [[1, "a"]], {}))
                                      .result(timeout=10))[1:]
        assert ok and value == [1, "a"]
        rec = EchoNode().layouts()[1].empty()
        rec["q"], rec["client"], rec["seq"] = 1.0, 13, 0
        assert bytes(client.call("req", rec.tobytes()).result(timeout=10)) == b"\x01"
        with pytest.raises(RuntimeError, match="bytes"):
            client.call("call", np.zeros(4)).result(timeout=10)
    finally:
        client.close(timeout=1.0)
    assert wait_until(lambda: [13, 0] in c.handled())
