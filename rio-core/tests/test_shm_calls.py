"""The shm middleware's call channel: a shared-memory message area with a wake-up pipe each way.

Both ways of waiting are tested on this (x86) machine: watching the message counter in memory (what
x86 uses) and polling the pipe (what other architectures use).
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from rio.machine import host
from rio.middleware import shm_calls
from rio.middleware.shm_calls import CallChannel, PeerGone
from rio.runtime import wire

WAYS = [pytest.param(True, id="watch-memory"), pytest.param(False, id="poll-pipe")]


def channel_pair(watch_memory: bool) -> tuple[CallChannel, CallChannel]:
    mem = host.anonymous_memory("rio-test", 16 + 4096)  # a small area, so growth is exercised
    a_r, a_w = os.pipe()
    b_r, b_w = os.pipe()
    client = CallChannel(mem, b_r, a_w, watch_memory=watch_memory)
    node = CallChannel(os.dup(mem), a_r, b_w, watch_memory=watch_memory)
    return client, node


class Idle(Exception):
    pass


def _idle() -> None:
    raise Idle


@pytest.mark.parametrize("watch_memory", WAYS)
def test_messages_alternate_and_the_area_grows_both_ways(watch_memory):
    client, node = channel_pair(watch_memory)
    try:
        for n in (10, 5_000, 300_000, 100):  # 5 kB and 300 kB do not fit the 4 kB area
            x = np.random.default_rng(n).random(n)
            client.send(wire.call_message("echo", (x,), {}))
            method, args, _ = wire.read_call(node.receive(0.0, 1.0, _idle))
            assert method == "echo"
            node.send(wire.reply_message(True, np.concatenate([args[0], args[0]])))
            ok, y = wire.read_reply(client.receive(0.0, 1.0, _idle))
            assert ok and y.shape == (2 * n,)
            np.testing.assert_array_equal(y[n:], x)
    finally:
        client.close()
        node.close()


@pytest.mark.parametrize("watch_memory", WAYS)
def test_no_message_means_waiting_even_with_old_wake_ups_pending(watch_memory):
    """Messages caught while spinning leave their wake-up bytes in the pipe; those must not be
    taken for a new message later."""
    client, node = channel_pair(watch_memory)
    try:
        for i in range(50):
            client.send((b"call %d" % i, ()))
            assert bytes(node.receive(1e-3, 1.0, _idle)) == b"call %d" % i
            node.send((b"reply", ()))
            assert bytes(client.receive(1e-3, 1.0, _idle)) == b"reply"
        with pytest.raises(Idle):
            node.receive(1e-4, 0.01, _idle)
        client.send((b"late", ()))
        assert bytes(node.receive(0.0, 1.0, _idle)) == b"late"
    finally:
        client.close()
        node.close()


@pytest.mark.parametrize("watch_memory", WAYS)
def test_closed_peer_is_reported_not_waited_for(watch_memory):
    client, node = channel_pair(watch_memory)
    node.close()
    t0 = time.monotonic()
    with pytest.raises(PeerGone):
        client.receive(1e-4, 5.0, _idle)  # a hang-up ends the wait long before the 5 s step
    assert time.monotonic() - t0 < 1.0
    with pytest.raises(PeerGone):
        client.send((b"anyone?", ()))
    client.close()


@pytest.mark.parametrize("watch_memory", WAYS)
def test_a_wait_without_deadline_ends_on_hang_up(watch_memory):
    """The node's serving thread sleeps with no deadline; its client going away must end it."""
    client, node = channel_pair(watch_memory)
    outcome: list[BaseException] = []

    def serve() -> None:
        try:
            node.receive(1e-4)
        except BaseException as e:  # noqa: BLE001 - inspected below
            outcome.append(e)

    t = threading.Thread(target=serve)
    t.start()
    time.sleep(0.05)
    client.close()
    t.join(2.0)
    assert not t.is_alive() and len(outcome) == 1 and isinstance(outcome[0], PeerGone)
    node.close()


def test_a_message_sent_just_before_hanging_up_is_still_delivered():
    client, node = channel_pair(True)
    node.send((b"last words", ()))
    node.close()
    assert bytes(client.receive(0.0, 1.0, _idle)) == b"last words"
    with pytest.raises(PeerGone):
        client.receive(0.0, 1.0, _idle)
    client.close()


# The node side runs in its own interpreter (a script, not a multiprocessing target: spawned
# children cannot import test modules by name under pytest's importlib mode).
_ECHO_NODE = """
import socket, sys, time
from rio.middleware import shm_calls
with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as listener:
    listener.bind(sys.argv[1])
    listener.listen(1)
    print("ready", flush=True)
    conn, _ = listener.accept()
    with conn:
        channel = shm_calls.accept_channel(conn)
while True:
    message = channel.receive(1e-4)
    if bytes(message[:4]) == b"stop":
        time.sleep(60)  # stays silent: the client must be told when this process is killed
    channel.send((bytes(message), ()))
"""


def test_across_processes_and_a_killed_node_is_noticed_at_once(tmp_path):
    path = str(tmp_path / "node.sock")
    proc = subprocess.Popen([sys.executable, "-c", _ECHO_NODE, path], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "ready"
        channel = shm_calls.open_client_channel(path, 10.0)
        for i in range(200):
            channel.send((b"ping %d" % i, ()))
            assert bytes(channel.receive(5e-5, 1.0, _idle)) == b"ping %d" % i
        channel.send((b"stop", ()))
        os.kill(proc.pid, signal.SIGKILL)
        t0 = time.monotonic()
        with pytest.raises(PeerGone):
            channel.receive(5e-5, 5.0, _idle)
        assert time.monotonic() - t0 < 1.0
        channel.close()
    finally:
        proc.kill()
        proc.wait(5)
        proc.stdout.close()


def test_a_connection_that_is_not_a_call_channel_is_refused():
    a, b = socket.socketpair()
    with a, b:
        a.sendall(b"GET / HTTP/1.1\r\n")
        with pytest.raises(ConnectionError, match="not a rio call channel"):
            shm_calls.accept_channel(b, timeout_s=1.0)


def test_closing_a_channel_twice_leaves_numbers_reused_since_alone():
    """A client's failing call and its close() from another thread may both drop its channel: the second
    close must not close what the process opened since under the same fd numbers (a recorder's encoder
    socket lost that way sees EOF and exits)."""
    client, node = channel_pair(watch_memory=False)
    client.close()
    reused = [os.open(os.devnull, os.O_RDONLY) for _ in range(3)]  # the lowest free numbers: client's old ones
    try:
        client.close()
        for fd in reused:
            os.fstat(fd)  # still open
    finally:
        for fd in reused:
            os.close(fd)
        node.close()
