"""shm-specific behaviour of API calls, beyond the conformance suite: deadlines, many clients,
and a node killed in the middle of a call."""

from __future__ import annotations

import os
import signal
import threading
import time

import numpy as np
import pytest
import rio
from rio import ServerManager, connect, serve
from rio.middleware.shm import ShmMiddleware
from rio.testing import EchoNode


@pytest.fixture(scope="module")
def manager():
    with ServerManager("shm", [serve(EchoNode, name="echo")]) as mgr:
        yield mgr


def test_call_timeout_then_the_next_call_gets_its_own_reply(manager):
    with connect(EchoNode, ShmMiddleware(call_timeout=0.2), name="echo") as c:
        with pytest.raises(rio.NodeTimeout, match="echo"):
            c.sleep(0.5)
        time.sleep(0.4)  # calls run one at a time under the node's lock: let `sleep` finish
        # The late reply of `sleep` must never be taken for this call's: the client opened a new
        # channel, and the node's serving thread of the old one ends when it finds it closed.
        x = np.arange(5.0)
        np.testing.assert_array_equal(c.echo(x), x)
        assert c.sleep(0.01) == 0.01


def test_many_clients_each_get_their_own_replies(manager):
    errors: list[BaseException] = []

    def client(k: int) -> None:
        try:
            with connect(EchoNode, "shm", name="echo") as c:
                for i in range(100):
                    x = np.full(k + 1, float(i))
                    np.testing.assert_array_equal(c.echo(x), x)
        except BaseException as e:  # noqa: BLE001 - reported by the main thread
            errors.append(e)

    threads = [threading.Thread(target=client, args=(k,)) for k in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    assert not errors, errors


def test_node_killed_during_a_call_is_reported_within_a_second():
    with ServerManager("shm", [serve(EchoNode, name="victim")]):
        with connect(EchoNode, "shm", name="victim") as c:
            pid = c.pid()
            threading.Timer(0.2, os.kill, (pid, signal.SIGKILL)).start()
            t0 = time.monotonic()
            with pytest.raises(rio.NodeDiedError, match="victim"):
                c.sleep(30.0)
            assert time.monotonic() - t0 < 1.2  # 0.2 s until the kill, then well under a second
