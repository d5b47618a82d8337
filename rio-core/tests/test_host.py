"""rio.machine.host: the operating-system calls that differ between Linux, macOS and Windows.

This machine is Linux. The macOS paths (temporary files for anonymous memory, polled process
liveness, 31-character shm names, the marker registry) are exercised by switching `host.FALLBACK`
on in-process, and by a run of the shared-memory suites in a subprocess with RIO_HOST_FALLBACK=1.
Windows is simulated only as far as "no POSIX shared memory": the refusal message is checked.
"""

from __future__ import annotations

import json
import mmap
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rio.errors import ConfigError
from rio.machine import host

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture
def fallback(monkeypatch):
    monkeypatch.setattr(host, "FALLBACK", True)


@pytest.mark.usefixtures("fallback")
def test_fallback_names_fit_macos_and_objects_are_listed_through_the_registry():
    name = f"rio-sim-{os.getuid()}-{os.getpid()}-abcdef-a-long-world-name"
    assert len(host._os_name(name)) <= 31 and host._os_name(name) == host._os_name(name)
    assert host._os_name("rio_x_d") == "/rio_x_d"  # short names are kept as they are
    fd = host.shm_create(name, 4096)
    try:
        assert name in host.shm_list("rio-sim-")
        with pytest.raises(FileExistsError):
            host.shm_create(name, 4096)
        other = host.shm_open(name)
        mm = mmap.mmap(other, 4096)
        mm[:5] = b"hello"
        assert mmap.mmap(fd, 4096)[:5] == b"hello"
        os.close(other)
    finally:
        os.close(fd)
        assert host.shm_unlink(name)
    assert name not in host.shm_list("rio-sim-") and not host.shm_unlink(name)


@pytest.mark.usefixtures("fallback")
def test_fallback_anonymous_memory_leaves_no_file_and_liveness_is_polled():
    fd = host.anonymous_memory("rio-test", 8192)
    assert os.fstat(fd).st_size == 8192 and os.fstat(fd).st_nlink == 0
    os.close(fd)
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    assert host.process_exit_watch(child.pid) is None
    deadline = time.monotonic() + 30
    while host.pid_alive(child.pid) and time.monotonic() < deadline:  # exited, not yet reaped: a zombie
        time.sleep(0.01)
    assert not host.pid_alive(child.pid)
    child.wait()
    assert host.pid_alive(os.getpid())


_HELPER = """
import os, subprocess, sys
helper = subprocess.Popen([sys.executable, "-c", "import os, time; from rio.machine import host; "
                           f"host.exit_with_parent({os.getpid()}); print('armed', flush=True); time.sleep(120)"],
                          stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
assert helper.stdout.readline().strip() == "armed"
print(helper.pid, flush=True)
os.kill(os.getpid(), 9)  # the parent dies without cleaning up
"""


@pytest.mark.parametrize("fallback", ["0", "1"], ids=["native", "portable"])
def test_a_helper_process_exits_with_the_parent_that_was_killed(fallback):
    """PR_SET_PDEATHSIG natively; the polling thread macOS and Windows use, forced on Linux."""
    env = {**os.environ, "RIO_HOST_FALLBACK": fallback}
    parent = subprocess.run([sys.executable, "-c", _HELPER], capture_output=True, text=True, env=env, timeout=120)
    assert parent.returncode == -9, parent.stderr
    helper = int(parent.stdout.split()[-1])
    deadline = time.monotonic() + 30
    while host.pid_alive(helper) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not host.pid_alive(helper), "the helper outlived its parent"


def test_without_posix_shared_memory_the_shm_middleware_names_the_alternatives(monkeypatch, capsys):
    monkeypatch.setattr(host, "_posixshmem", None)
    with pytest.raises(ConfigError, match="thread, zmq or zenoh.*WSL2"):
        host.require_shared_memory("the shm middleware")
    from rio.middleware.shm import ShmMiddleware

    with pytest.raises(ConfigError, match="the shm middleware needs POSIX shared memory"):
        ShmMiddleware().prepare(None, "/tmp")  # type: ignore[arg-type]
    from rio.cli import main

    assert main(["doctor", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    shm = next(r for r in data["middlewares"] if r["middleware"] == "shm")
    assert not shm["ok"] and "WSL2" in shm["install"] and data["host"] == host.describe()


def test_file_lock_is_exclusive_across_descriptors(tmp_path):
    a = os.open(tmp_path / "lock", os.O_RDWR | os.O_CREAT)
    b = os.open(tmp_path / "lock", os.O_RDWR)
    assert host.try_lock(a) and not host.try_lock(b)
    os.close(a)
    assert host.try_lock(b)
    os.close(b)


@pytest.mark.slow
def test_shared_memory_suites_pass_on_the_portable_paths():
    """The middleware conformance kit on shm (its memory, locks and process watch) and on zmq (the process
    watch of every network middleware's client, `rio.runtime.transport.ProcessWatch`; zenoh's and the
    portal's are the same code), the shm middleware and call-channel tests, crash-safe recording and the sim
    world bus, re-run with RIO_HOST_FALLBACK=1: what macOS runs, on this Linux machine."""
    suites = ["rio-core/tests/test_conformance.py::TestShm", "rio-core/tests/test_conformance.py::TestZmq",
              "rio-core/tests/test_mw_shm.py",
              "rio-core/tests/test_shm_calls.py", "rio-core/tests/test_recording_crash.py",
              "plugins/rio-sim/tests/test_bus.py"]
    env = {**os.environ, "RIO_HOST_FALLBACK": "1"}
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-n", "0", "-p", "no:cacheprovider", *suites],
                         cwd=REPO, env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]
    assert " passed" in run.stdout and "failed" not in run.stdout


def test_a_plugins_tests_skip_saying_why_where_its_sdk_has_no_wheel():
    """`rio.testing.skip_tests_without`, used by rio-franka's and rio-ur's conftests (franky-control and
    ur-rtde have no aarch64 or macOS wheels)."""
    from rio.testing import skip_tests_without

    class Item:
        def __init__(self, path):
            self.path, self.markers = Path(path), []

        def add_marker(self, marker):
            self.markers.append(marker)

    items = [Item("/r/plugins/rio-ur/tests/test_arm.py"), Item("/r/plugins/rio-so100/tests/test_arm.py")]
    skip_tests_without("rio_no_such_sdk", "no wheel here", items, "rio-ur")
    assert [len(i.markers) for i in items] == [1, 0]
    assert items[0].markers[0].kwargs["reason"] == "rio_no_such_sdk is not installed (no wheel here)"
    skip_tests_without("numpy", "installed", items[1:], "rio-so100")
    assert items[1].markers == []
