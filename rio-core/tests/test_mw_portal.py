"""The portal middleware against rio.testing nodes (a spawned server process per node)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

pytest.importorskip("portal")

import rio  # noqa: E402
from rio.errors import ConfigError  # noqa: E402
from rio.manager import ServerManager, connect, serve  # noqa: E402
from rio.middleware.portal import PortalMiddleware  # noqa: E402
from rio.testing import EchoNode, ImageNode, wait_until  # noqa: E402

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
        c.send_request(q=np.full(6, float(i)), client=7, seq=i)
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
    assert ei.value.exc_type == "ValueError" and "fail" in ei.value.remote_traceback
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
    """A record that skipped client-side validation (a foreign client): refused by the server too."""
    from rio.middleware.portal import _Reply

    _, c = echo
    rec = EchoNode().layouts()[1].empty()
    rec["q"], rec["client"], rec["seq"] = np.nan, 3, 1
    reply = _Reply()
    c._transport._conn.send(b"req", rec.tobytes(), reply)
    assert reply.event.wait(2.0) and b"NaN" in bytes(reply.data)
    c.send_request(q=np.zeros(6), client=3, seq=2)
    assert wait_until(lambda: [3, 2] in c.handled())
    assert [3, 1] not in c.handled()


def test_non_bytes_messages_are_dropped(echo):
    """portal would decode e.g. a SharedArray leaf (attach + unlink a segment): the server drops them."""
    mgr, c = echo
    from rio.middleware.portal import _portal

    portal = _portal()
    raw = portal.Client(f"127.0.0.1:{mgr.address('echo')['port']}", logging=False)
    try:
        fut = raw.call("call", np.zeros(4))  # an array leaf, not bytes
        with pytest.raises(TimeoutError):
            fut.result(timeout=0.3)
        assert bytes(raw.call("req", b"\x00").result(timeout=2.0))  # bytes pass (refused: wrong size)
    finally:
        raw.close(timeout=1.0)
    assert c.echo(2) == 2


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
            os.kill(pid, signal.SIGSTOP)
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


def test_start_method_unchanged():
    """`import portal` sets the spawn start method program-wide; the middleware must undo that."""
    code = textwrap.dedent("""
        import multiprocessing as mp
        import numpy as np
        from rio.manager import ServerManager, connect, serve
        from rio.middleware.portal import _portal
        from rio.testing import EchoNode

        if __name__ == "__main__":
            assert mp.get_start_method(allow_none=True) is None
            _portal()  # what make_server does first
            assert mp.get_start_method(allow_none=True) is None, mp.get_start_method(allow_none=True)
            mp.set_start_method("forkserver")
            with ServerManager("portal", [serve(EchoNode, name="echo", rate_hz=20.0)]):
                with connect(EchoNode, "portal", name="echo") as c:
                    assert c.echo(np.ones(3)).sum() == 3
            print("START", mp.get_start_method(allow_none=True))
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert "START forkserver" in out.stdout
