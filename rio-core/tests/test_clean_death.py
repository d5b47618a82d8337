"""Every way a station's process dies leaves this machine clean.

- SIGKILL of the process holding a shm `ServerManager`: nothing in it can react; its nodes exit by
  themselves (parent-death signal), and the next `ServerManager` start, or `sweep_dead_runs()`, removes
  its segments and run directory, but never a live run's.
- A second signal while stopping (`uv run` forwards Ctrl+C, so a program gets SIGINT twice): the stop
  finishes, then the signal is delivered.
- A KeyboardInterrupt that escapes before `__exit__`: the exit hook stops the station.
- The sweep's rules, on made-up leftovers: dead, live, starting, unknown, another pid namespace's.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import pytest

from rio import ServerManager, serve
from rio.machine import host
from rio.runtime.manager import sweep_dead_runs
from rio.runtime.sweep import MANIFEST, marker_name
from rio.testing import Counter, wait_until

pytestmark = pytest.mark.skipif(not host.has_shared_memory(), reason="needs POSIX shared memory")

#: A node whose close() is slow, so that a test can signal the manager while it stops; it touches
#: `flag` when close() begins.
SLOW_NODE = '''
import pathlib, time
from rio.runtime.node import Node, NodeConfig

class SlowClose(Node):
    class Config(NodeConfig):
        rate_hz: float = 50.0
        flag: str = ""
        close_s: float = 2.0

    def setup(self):
        self.example_data = {"i": 0}
        self.i = 0

    def read_state(self):
        self.i += 1
        return {"i": self.i}

    def close(self):
        pathlib.Path(self.config.flag).touch()
        time.sleep(self.config.close_s)
'''

#: A station holding shm nodes until it is signalled or killed; prints its run id, run directory and
#: node pids as one JSON line once ready. `exit` instead of waiting: leave without `__exit__`.
STATION = '''
import json, os, sys, time
from rio import ServerManager, serve
from rio.machine import host
from rio.testing import Counter, EchoNode
from slow_node import SlowClose

if __name__ == "__main__":
    kind, flag = sys.argv[1], sys.argv[2]
    nodes = {"two": [serve(Counter, name="c", rate_hz=50), serve(EchoNode, name="e", rate_hz=50)],
             "one": [serve(Counter, name="c", rate_hz=50)],
             "slow": [serve(SlowClose, name="slow", flag=flag)]}[kind if kind not in ("exit", "fork") else "one"]
    mgr = ServerManager("shm", nodes)
    mgr.__enter__()
    try:
        print(json.dumps({"run_id": mgr.run_id, "run_dir": mgr.run_dir, "pids": mgr.pids()}), flush=True)
        if kind == "exit":
            sys.exit(0)  # never reaches __exit__: the exit hook must stop the station
        if kind == "fork":
            before = host.shm_list(f"rio_{mgr.run_id}_")
            child = os.fork()
            if child == 0:
                sys.exit(0)  # a normal exit: the exit hooks run, but the station is not the child's
            os.waitpid(child, 0)
            print(json.dumps({"kept": host.shm_list(f"rio_{mgr.run_id}_") == before and len(before) == 2,
                              "alive": all(host.pid_alive(p) for p in mgr.pids().values())}), flush=True)
            mgr.__exit__(None, None, None)
            sys.exit(0)
        while True:
            time.sleep(0.05)
    except SystemExit:
        raise
    except BaseException:
        mgr.__exit__(*sys.exc_info())
        raise
'''


@pytest.fixture
def scripts(tmp_path: Path) -> Path:
    (tmp_path / "slow_node.py").write_text(textwrap.dedent(SLOW_NODE))
    (tmp_path / "station.py").write_text(textwrap.dedent(STATION))
    return tmp_path


def _launch(scripts: Path, kind: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(scripts), os.environ.get("PYTHONPATH")]))}
    return subprocess.Popen([sys.executable, str(scripts / "station.py"), kind, str(scripts / "closing")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)


def _ready(proc: subprocess.Popen) -> dict:
    assert proc.stdout is not None
    line = proc.stdout.readline()
    if not line:
        proc.wait(30)
        pytest.fail(f"station did not start:\n{proc.stderr.read() if proc.stderr else ''}")
    return json.loads(line)


def _start(scripts: Path, kind: str) -> tuple[subprocess.Popen, dict]:
    proc = _launch(scripts, kind)
    return proc, _ready(proc)


def _leftovers(info: dict) -> set[str]:
    return host.shm_list(f"rio_{info['run_id']}_")


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)


# -- SIGKILL, then a sweep ------------------------------------------------------------------------------
@pytest.mark.parametrize("sweeper", ["function", "manager start"])
def test_a_sigkilled_stations_leftovers_are_swept_and_a_live_ones_are_not(scripts, sweeper, caplog):
    dead, live = _launch(scripts, "two"), _launch(scripts, "one")  # started side by side: both live
    try:
        dead_info, live_info = _ready(dead), _ready(live)
        live_before = _leftovers(live_info)
        assert len(live_before) == 2  # the ring's segment and the run's marker
        dead.kill()
        dead.wait(10)
        assert wait_until(lambda: not any(host.pid_alive(p) for p in dead_info["pids"].values()), timeout=15), \
            "node processes outlived their SIGKILLed manager"
        left = _leftovers(dead_info)
        segments = {n for n in left if n.endswith(("_d", "_r"))}
        # a SIGKILLed manager leaves its segments and run directory; any manager start on this machine (another
        # test worker's, another test run's) sweeps them at once, possibly before this line: then all are gone
        swept_elsewhere = not segments and not os.path.isdir(dead_info["run_dir"])
        assert swept_elsewhere or (len(segments) == 3 and os.path.isdir(dead_info["run_dir"])), (left, dead_info)

        if sweeper == "function":
            # Other dead runs of this machine may be swept with it; and on a machine shared with other
            # test runs, another process's ServerManager start may have swept this one first.
            swept = sweep_dead_runs()
            assert live_info["run_id"] not in swept.runs
            if dead_info["run_id"] in swept.runs:
                assert {n for n in swept.segments if dead_info["run_id"] in n} == segments
                assert dead_info["run_dir"] in swept.dirs and swept.nbytes > 0
        else:
            caplog.set_level("WARNING", logger="rio.runtime.manager")
            with ServerManager("thread", [serve(Counter, name="t")]):
                pass
            lines = [r.getMessage() for r in caplog.records if "swept" in r.getMessage()]
            assert all("shared-memory segment(s)" in line and " MB" in line for line in lines), lines

        assert not _leftovers(dead_info) and not os.path.exists(dead_info["run_dir"])
        assert _leftovers(live_info) == live_before and os.path.isdir(live_info["run_dir"])
        assert live.poll() is None
    finally:
        dead.kill()
        _stop(live)
    assert live.returncode == -signal.SIGINT  # KeyboardInterrupt after a complete stop
    assert not _leftovers(live_info) and not os.path.exists(live_info["run_dir"])


# -- a second signal while stopping -------------------------------------------------------------------
@pytest.mark.parametrize("second", [signal.SIGINT, signal.SIGTERM])
def test_a_second_signal_while_stopping_waits_for_the_cleanup(scripts, second):
    proc, info = _start(scripts, "slow")
    try:
        proc.send_signal(signal.SIGINT)
        assert wait_until(lambda: (scripts / "closing").exists(), timeout=15), "the node never began to close"
        proc.send_signal(second)
        _, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert not _leftovers(info), "segments leaked by an interrupted stop"
    assert not os.path.exists(info["run_dir"])
    assert proc.returncode == -second, err  # delivered after the cleanup, to the handler in place before
    assert f"{second.name}: stopping the nodes" in err  # held back, not raised in the middle of the stop
    assert "was not stopped" not in err  # the exit hook (the last resort) had nothing to do


def test_a_station_left_without_exit_is_stopped_at_interpreter_exit(scripts):
    proc, info = _start(scripts, "exit")
    try:
        proc.wait(30)
    finally:
        proc.kill()
    assert proc.returncode == 0
    assert not _leftovers(info) and not os.path.exists(info["run_dir"])
    assert not any(host.pid_alive(p) for p in info["pids"].values())


def test_a_forked_child_exiting_leaves_its_parents_station_alone(scripts):
    proc, info = _start(scripts, "fork")
    try:
        out, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    assert json.loads(out) == {"kept": True, "alive": True}
    assert not _leftovers(info) and not os.path.exists(info["run_dir"])


# -- the sweep's rules ----------------------------------------------------------------------------------
def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def _age(path: str, seconds: float) -> None:
    t = time.time() - seconds
    os.utime(path, (t, t))


def test_sweep_rules_on_made_up_leftovers():
    base = tempfile.mkdtemp(prefix="rcd", dir="/tmp")
    ids = {k: os.urandom(4).hex() for k in ("dead", "live", "starting", "stale", "marked", "foreign_ns",
                                          "unknown_young", "unknown_old")}
    made: list[str] = []

    def segment(key: str, suffix: str = "d") -> str:
        name = f"rio_{ids[key]}_{os.urandom(4).hex()}_{suffix}"
        os.close(host.shm_create(name, 4096))
        made.append(name)
        return name

    def marker(key: str, name: str) -> str:
        os.close(host.shm_create(name, 8))
        made.append(name)
        return name

    def run_dir(key: str, pid: int | None) -> str:
        path = tempfile.mkdtemp(prefix=f"rio-{ids[key]}-", dir=base)
        if pid is not None:
            Path(path, MANIFEST).write_text(json.dumps({"pid": pid, "pidns": host.pid_namespace()}))
        return path

    try:
        dead_seg, dead_dir = segment("dead"), run_dir("dead", _dead_pid())
        live_seg, live_dir = segment("live"), run_dir("live", os.getpid())
        starting_seg, starting_dir = segment("starting"), run_dir("starting", None)
        stale_dir = run_dir("stale", None)
        _age(stale_dir, 120)
        marked_seg = segment("marked")
        marked = marker("marked", marker_name(ids["marked"]))
        foreign_seg = segment("foreign_ns")
        foreign = marker("foreign_ns", f"rio_{ids['foreign_ns']}_p{_dead_pid()}_n1")
        young_seg, old_seg = segment("unknown_young"), segment("unknown_old")
        old_stat = host.shm_stat(old_seg)
        assert old_stat is not None
        _age(os.path.join(host.registry_dir() if host.FALLBACK else "/dev/shm", old_seg), 120)
        not_a_run = f"rio_x_{os.urandom(4).hex()}_d"  # `prepare` outside a run directory
        os.close(host.shm_create(not_a_run, 4096))
        made.append(not_a_run)
        _age(os.path.join(host.registry_dir() if host.FALLBACK else "/dev/shm", not_a_run), 120)

        swept = sweep_dead_runs(bases=[base])

        kept = {live_seg, starting_seg, marked_seg, marked, foreign_seg, foreign, young_seg, not_a_run}
        assert kept <= host.shm_list("rio_"), kept - host.shm_list("rio_")
        assert not kept & set(swept.segments)
        assert os.path.isdir(live_dir) and os.path.isdir(starting_dir)
        assert dead_seg not in host.shm_list("rio_") and old_seg not in host.shm_list("rio_")
        assert dead_seg in swept.segments and sorted(swept.dirs) == sorted([dead_dir, stale_dir])
        assert not os.path.exists(dead_dir) and not os.path.exists(stale_dir)
        assert ids["dead"] in swept.runs and ids["live"] not in swept.runs
        assert swept.nbytes >= 4096 and "dead run(s)" in swept.summary()
    finally:
        for name in made:
            host.shm_unlink(name)
        import shutil

        shutil.rmtree(base, ignore_errors=True)


def test_a_manager_marks_its_run_before_its_segments_and_unmarks_it_last():
    with ServerManager("shm", [serve(Counter, name="c", rate_hz=50)]) as mgr:
        ours = host.shm_list(f"rio_{mgr.run_id}_")
        assert marker_name(mgr.run_id) in ours
        assert mgr.run_dir is not None
        manifest = json.loads(Path(mgr.run_dir, MANIFEST).read_text())
        assert manifest["pid"] == os.getpid() and manifest["nodes"][0]["name"] == "c"
        assert not sweep_dead_runs().runs & {mgr.run_id}
        assert host.shm_list(f"rio_{mgr.run_id}_") == ours
    assert not host.shm_list(f"rio_{mgr.run_id}_")


def test_a_manager_start_sweeps_and_says_what_it_swept(monkeypatch, caplog):
    import shutil

    from rio.runtime import sweep

    base = tempfile.mkdtemp(prefix="rcd", dir="/tmp")
    run_id = os.urandom(4).hex()
    name = f"rio_{run_id}_{os.urandom(4).hex()}_d"
    path = tempfile.mkdtemp(prefix=f"rio-{run_id}-", dir=base)
    Path(path, MANIFEST).write_text(json.dumps({"pid": _dead_pid()}))
    os.close(host.shm_create(name, 2_000_000))
    monkeypatch.setattr(sweep, "_bases", lambda: [base])
    caplog.set_level("WARNING", logger="rio.runtime.manager")
    try:
        with ServerManager("thread", [serve(Counter, name="t")]):
            pass
        assert name not in host.shm_list("rio_") and not os.path.exists(path)
        lines = [r.getMessage() for r in caplog.records if "swept" in r.getMessage()]
        # at least this segment and directory (other dead runs of this machine may be swept with them)
        assert len(lines) == 1 and re.search(r"run\(s\): [1-9]\d* shared-memory segment\(s\), \d+\.\d MB, "
                                             r"[1-9]\d* run directory", lines[0]), lines
    finally:
        host.shm_unlink(name)
        shutil.rmtree(base, ignore_errors=True)


def test_a_ctrl_c_while_a_node_process_starts_does_not_kill_it():
    """Ctrl-C in a terminal reaches every process of its group, node processes included. One that arrived
    while a node's interpreter was still starting (importing `site`, before the node ignores SIGINT) killed
    it with "Fatal Python error: init_import_site" and a traceback (seen when a `rio teleop` was interrupted
    during start-up on a loaded machine). Node processes now start with SIGINT blocked: here every new one is
    sent SIGINT every millisecond from its first moment, and the station still comes up."""
    import threading

    import psutil

    me, stop, hit = psutil.Process(), threading.Event(), set()

    def interrupt_every_new_node() -> None:
        while not stop.is_set():
            for child in me.children():
                try:
                    if "spawn_main" in " ".join(child.cmdline()):
                        child.send_signal(signal.SIGINT)
                        hit.add(child.pid)
                except psutil.Error:  # gone, or not yet readable
                    pass
            time.sleep(0.001)

    flood = threading.Thread(target=interrupt_every_new_node, daemon=True)
    flood.start()
    try:
        with ServerManager("shm", [serve(Counter, name="counter")]) as mgr:
            pid = mgr.pids()["counter"]
            stop.set()
            flood.join()
            assert psutil.pid_exists(pid) and pid in hit, (pid, hit)
    finally:
        stop.set()
        flood.join()
