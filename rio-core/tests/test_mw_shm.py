"""shm-specific behaviour of API calls, beyond the conformance suite: deadlines, many clients,
a node killed in the middle of a call, and a client inherited through fork."""

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
from rio.testing import EchoNode, wait_until


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


def test_a_forked_child_can_use_the_parents_client(manager):
    """`multiprocessing`'s default start method on Linux is fork: a worker may inherit a connected
    client. Parent and child then call and send requests at the same time; each must get its own
    replies, and no request may be lost or torn."""
    n = 300
    with connect(EchoNode, "shm", name="echo") as c:
        c.echo(np.zeros(3))  # the parent's call channel exists before the fork
        before = len(c.handled())
        pid = os.fork()
        if pid == 0:  # child: report through the exit code only
            code = 1
            try:
                for seq in range(n):
                    c.send_request(q=np.full(6, float(seq)), client=7, seq=seq)
                    x = np.full(4, float(seq))
                    if not np.array_equal(c.echo(x), x):
                        break
                else:
                    code = 0
            finally:
                os._exit(code)
        for seq in range(n):
            c.send_request(q=np.full(6, -float(seq)), client=8, seq=seq)
            x = np.full(5, -float(seq))
            np.testing.assert_array_equal(c.echo(x), x)
        _, status = os.waitpid(pid, 0)
        assert os.waitstatus_to_exitcode(status) == 0, "the forked child got a wrong reply or an error"
        assert wait_until(lambda: len(c.handled()) - before >= 2 * n), "requests were lost"
        got = [tuple(x) for x in c.handled()[before:]]
        for cid in (7, 8):
            assert [s for k, s in got if k == cid] == list(range(n)), f"client {cid} lost or reordered requests"


def test_a_node_process_that_cannot_start_leaves_no_shared_memory(monkeypatch):
    """Seen on this machine: a script without a `__main__` guard makes every spawned node fail to start;
    the segments made for it stayed in /dev/shm because the node was not yet the manager's to release."""
    import multiprocessing.context

    from rio.testing import Counter

    def refuse(self):
        raise RuntimeError("cannot start a process now")

    monkeypatch.setattr(multiprocessing.context.SpawnProcess, "start", refuse)
    manager = ServerManager("shm", [serve(Counter, name="c", rate_hz=10)])
    with pytest.raises(RuntimeError, match="cannot start a process now"):
        manager.__enter__()
    assert not [n for n in os.listdir("/dev/shm") if f"_{manager.run_id}_" in n]


def test_a_deep_temp_directory_does_not_break_the_node_sockets(monkeypatch, tmp_path):
    """A `TMPDIR` too deep for AF_UNIX socket paths (108 bytes on Linux) made every shm node fail to bind
    ("AF_UNIX path too long"); run directories then go to /tmp, and `rio top` looks for them there too."""
    import tempfile

    from rio.machine import host
    from rio.runtime.top import running_stations
    from rio.testing import Counter

    deep = tmp_path / ("d" * 60) / ("e" * 60)
    deep.mkdir(parents=True)
    monkeypatch.setattr(tempfile, "tempdir", str(deep))
    assert host.run_dir_base() == "/tmp"
    with ServerManager("shm", [serve(Counter, name="c", rate_hz=50)]) as m, connect(Counter, "shm", name="c") as c:
        assert m.run_dir.startswith("/tmp/rio-")
        assert wait_until(lambda: c.get_state()["i"] >= 2, timeout=10)
        assert any(s["pid"] == os.getpid() for s in running_stations())
    monkeypatch.setattr(tempfile, "tempdir", "/tmp")
    assert host.run_dir_base() == "/tmp"
