"""Who may hold a connection to a node (rio.middleware.protocol.admission; portal and zmq, whose peers are
connections): connections that never finish the handshake lock nobody out, silent ones are closed, and a
client refused for want of room is told "too many connections", not that the node is not running. Attacks
are raw TCP sockets."""

from __future__ import annotations

import socket
import time

import pytest

from rio.errors import NodeDiedError, TooManyConnections
from rio.runtime.manager import ServerManager, connect, serve
from rio.testing import EchoNode


def _idle(port: int) -> socket.socket:
    """A TCP connection that says nothing, ever (not even portal's handshake)."""
    return socket.create_connection(("127.0.0.1", port), timeout=30)


def test_idle_connections_that_never_handshake_lock_nobody_out():
    """Attack: 40 TCP connections that never send a byte (32 locked every new client out for as long as they
    stayed open, and the client was told the node "is not running"). The handshake timeout is long here, so
    what lets the client in is that a stranger gives way to a newcomer, not that it timed out."""
    with ServerManager("portal", [serve(EchoNode, name="lockout")], mw_options={"handshake_timeout_s": 300}) as mgr:
        port = mgr.address("lockout")["port"]
        idle = [_idle(port) for _ in range(40)]
        try:
            time.sleep(0.5)  # all accepted by the server
            with connect(EchoNode, "portal", name="lockout") as c:
                assert c.echo(2.5) == 2.5
                more = [_idle(port) for _ in range(40)]  # a second wave while the client is connected
                idle += more
                time.sleep(0.5)
                assert c.echo(3.5) == 3.5  # an established client never gives way to strangers
        finally:
            for s in idle:
                s.close()


def test_a_connection_without_handshake_is_closed_and_a_real_client_stays_past_the_idle_timeout():
    """A connection that never finishes the handshake is closed after handshake_timeout_s; a real client, whose
    long poll goes out every heartbeat, is never idle and stays connected past idle_timeout_s."""
    options = {"handshake_timeout_s": 1.0, "idle_timeout_s": 1.5}
    with ServerManager("portal", [serve(EchoNode, name="timeouts")], mw_options=options) as mgr:
        port = mgr.address("timeouts")["port"]
        with connect(EchoNode, "portal", name="timeouts") as c:
            s = _idle(port)
            t0 = time.monotonic()
            try:
                assert s.recv(1) == b""  # closed by the server (a 30 s socket timeout would raise)
            except ConnectionResetError:
                pass
            finally:
                s.close()
            waited = time.monotonic() - t0
            assert waited >= 0.9, waited  # not before handshake_timeout_s
            time.sleep(3.0)  # twice idle_timeout_s
            assert c.echo(1.5) == 1.5


@pytest.mark.parametrize("mw, per_client", [("portal", 1), ("zmq", 2)])
def test_a_node_without_room_says_too_many_connections(mw, per_client):
    """Clients that finished their handshake hold their slots (a zmq client has two connections, a portal
    client one); the next one is refused with the reason, as TooManyConnections (a RioError), not
    NodeDiedError ("not running") nor, on zmq, a failed authentication."""
    options = {"max_connections_per_address": 2 * per_client}
    with ServerManager(mw, [serve(EchoNode, name="full")], mw_options=options):
        with connect(EchoNode, mw, name="full") as a, connect(EchoNode, mw, name="full") as b:
            assert a.echo(1.0) == 1.0 and b.echo(2.0) == 2.0
            with pytest.raises(TooManyConnections, match="too many connections") as e:
                connect(EchoNode, mw, name="full")
            assert not isinstance(e.value, NodeDiedError) and "not running" not in str(e.value)
            assert a.echo(3.0) == 3.0  # the refusal cost the others nothing
        time.sleep(0.5)  # the server has seen them leave
        with connect(EchoNode, mw, name="full") as c:  # their slots are free again once they left
            assert c.echo(4.0) == 4.0
