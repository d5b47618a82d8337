"""Exit statuses that tell the truth, one table for every workflow (rio.cli.exit_status): `rio teleop`,
`rio deploy`, `rio replay`, `rio run` and `rio serve`, each run through the command line on a fake arm that
goes wrong on cue (`fail`): a node that stops with an error (4), a fault the device reports (5), a safety
stop that disables it (6), a normal end (0; `rio serve`, which only a signal ends: 130), and for deploy a
policy that returns NaN (4). Whatever went wrong is at the top of the summary. An expected node error is one
line on the console, never a traceback (the traceback is in the log, and shown with --debug)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rio.cli import main
from rio.cli.exit_status import EXIT_FAULT, EXIT_NODE_ERROR, EXIT_SAFETY_STOP

SLEEP = "rio.policy.testing:SleepPolicyNode,chunk=5"

STATION = """
name = "exit-{fail}"
rate_hz = 50
[middleware]
name = "{mw}"
[embodiment]
action_space = "eef_pose"
[components.arm]
driver = "rio.fake_arm"
dof = 3
{fail_lines}
[components.teleop]
driver = "teleop.scripted"
script = "square"
"""

CONTROLLER = """
class Hold:
    name = "hold"

    def reset(self, loop):
        self.start = loop.obs.observation.proprio.copy()

    def step(self, tick):
        return self.start

    def done(self):
        return None
"""

#: fail -> (exit status, the summary's `problem`)
CASES = {None: (0, None), "error": (EXIT_NODE_ERROR, "error"), "fault": (EXIT_FAULT, "fault"),
         "stop": (EXIT_SAFETY_STOP, "disabled")}


def station(tmp_path: Path, fail: str | None, mw: str = "thread", after_s: float = 0.4) -> str:
    path = tmp_path / f"exit-{fail}-{mw}.toml"
    lines = f'fail = "{fail}"\nfail_after_s = {after_s}' if fail else ""
    path.write_text(STATION.format(fail=fail or "none", mw=mw, fail_lines=lines))
    return str(path)


@pytest.fixture(scope="module")
def episode(tmp_path_factory) -> str:
    """A second of a fake arm holding its pose, recorded by `rio run`: what `rio replay` plays back."""
    root = tmp_path_factory.mktemp("replay")
    (root / "hold_ctl.py").write_text(CONTROLLER)
    sys.path.insert(0, str(root))
    data = root / "data"
    assert main(["run", station(root, None), "--controller", "hold_ctl:Hold", "--duration", "1",
                 "--record", str(data), "--json"]) == 0
    return str(data)


@pytest.fixture
def controller(tmp_path) -> str:
    (tmp_path / "hold_ctl.py").write_text(CONTROLLER)
    sys.path.insert(0, str(tmp_path))
    yield "hold_ctl:Hold"
    sys.path.remove(str(tmp_path))


def run(args: list[str], capsys) -> tuple[int, dict]:
    capsys.readouterr()
    code = main([*args, "--json"])
    out = capsys.readouterr().out
    return code, json.loads(out)


def check(code: int, summary: dict, fail: str | None) -> None:
    want_code, want_problem = CASES[fail]
    assert code == want_code, (code, summary["reason"], summary["events"])
    assert summary["problem"] == want_problem, summary["events"]
    if fail is None:
        assert summary["events"] == [], summary["events"]
        return
    (event,) = summary["events"]
    assert event["node"] == "arm" and event["kind"] == want_problem, event
    assert 0.1 < event["t_s"] < 1.5, event  # when it went wrong, in run time (~0.4 s after the first command)
    if fail == "error":
        assert "RioError: the fake arm stopped answering" in event["message"], event
    elif fail == "fault":
        assert event["message"].startswith("fake_fault (code 9): the fake arm reported a fault"), event


@pytest.mark.parametrize("fail", list(CASES))
def test_teleop(tmp_path, capsys, fail):
    code, summary = run(["teleop", station(tmp_path, fail), "--duration", "1.5"], capsys)
    check(code, summary, fail)


@pytest.mark.parametrize("fail", list(CASES))
def test_deploy(tmp_path, capsys, fail):
    code, summary = run(["deploy", station(tmp_path, fail), "--policy", SLEEP, "--duration", "1.5"], capsys)
    check(code, summary, fail)


def test_deploy_of_a_policy_returning_nan(tmp_path, capsys):
    code, summary = run(["deploy", station(tmp_path, None), "--policy",
                         "rio.policy.testing:NanPolicyNode,chunk=5,nan_after=2", "--duration", "5"], capsys)
    assert code == EXIT_NODE_ERROR, summary
    (event,) = summary["events"]
    assert event["node"] == "policy" and event["kind"] == "error", event
    assert event["message"] == ("PolicyError: policy 'testing.nan' returned a NaN or inf action (step 0, value 0 "
                                "of its chunk)"), event
    assert summary["reason"] == "node 'policy' stopped with an error; the robot holds its last command"
    assert summary["seconds"] < 4.0  # the run ended there, not at --duration


@pytest.mark.parametrize("fail", list(CASES))
def test_replay(tmp_path, capsys, episode, fail):
    code, summary = run(["replay", episode, "--station", station(tmp_path, fail, after_s=0.5), "--approach", "0.1"],
                        capsys)
    check(code, summary, fail)


def test_replay_whose_arm_is_lost_while_it_approaches_the_first_action(tmp_path, capsys, episode):
    code, summary = run(["replay", episode, "--station", station(tmp_path, "error"), "--approach", "2"], capsys)
    assert code == EXIT_NODE_ERROR, summary
    assert summary["reason"] == "node 'arm' stopped with an error before the first tick" and summary["ticks"] == 0
    (event,) = summary["events"]
    assert event["node"] == "arm" and event["t_s"] is None and "the fake arm stopped answering" in event["message"]


@pytest.mark.parametrize("fail", list(CASES))
def test_run(tmp_path, capsys, controller, fail):
    code, summary = run(["run", station(tmp_path, fail), "--controller", controller, "--duration", "1.5"], capsys)
    check(code, summary, fail)


def test_the_summary_says_what_went_wrong_at_its_top(tmp_path, capsys):
    capsys.readouterr()
    assert main(["teleop", station(tmp_path, "fault"), "--duration", "1.5"]) == EXIT_FAULT
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("teleop on 'exit-fault' with teleop.scripted: ")
    assert lines[1].startswith("  FAULT: node 'arm' at 0."), lines[:3]


# -- in their own processes: the console, rio serve ----------------------------------------------------------
def _rio(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "rio", *args], capture_output=True, text=True, timeout=timeout,
                          stdin=subprocess.DEVNULL, env={**os.environ, "RIO_DEBUG": "0", "COLUMNS": "200"})


@pytest.mark.parametrize("policy, node", [("rio.policy.testing:NanPolicyNode,chunk=5", "policy"), (SLEEP, "arm")])
def test_an_expected_node_error_is_one_line_on_the_console(tmp_path, policy, node):
    """A policy's NaN and a lost device (the fake arm's RioError), each in a node process of its own (shm):
    one line naming the node and the cause, above the summary; no traceback. `--debug` shows it."""
    st = station(tmp_path, "error" if node == "arm" else None, mw="shm")
    r = _rio("deploy", st, "--policy", policy, "--duration", "6")
    assert r.returncode == EXIT_NODE_ERROR, r.stdout + r.stderr
    assert "Traceback" not in r.stderr, r.stderr
    said = [ln for ln in r.stderr.splitlines() if "stopped with an error" in ln]
    assert len(said) == 1 and said[0].startswith(f"node '{node}' stopped with an error: "), r.stderr
    top = r.stdout.splitlines()[1]
    assert top.startswith(f"  ERROR: node '{node}' at ") and ("PolicyError" if node == "policy" else "RioError") \
        in top, r.stdout
    r = _rio("--debug", "deploy", st, "--policy", policy, "--duration", "6")
    assert r.returncode == EXIT_NODE_ERROR and "Traceback" in r.stderr, r.stderr


SERVE_STATION = """
name = "exit-serve-{fail}"
rate_hz = 50
[middleware]
name = "zmq"
[machines.robot]
address = "127.0.0.1"
nodes = ["arm"]
port = {port}
[components.arm]
driver = "rio.fake_arm"
dof = 3
{fail_lines}
[components.teleop]
driver = "teleop.scripted"
"""


@pytest.mark.parametrize("fail", list(CASES))
def test_serve(tmp_path, fail):
    """`rio serve` ends by itself when a node stops with an error; otherwise a signal ends it, and a fault or
    a safety stop while it served still decides the status."""
    import threading

    from rio.benchmarks.raw_transports import free_port
    from rio.station import make_station

    path = tmp_path / "serve.toml"
    lines = f'fail = "{fail}"\nfail_after_s = 0.5' if fail else ""
    path.write_text(SERVE_STATION.format(fail=fail or "none", port=free_port(), fail_lines=lines))
    proc = subprocess.Popen([sys.executable, "-m", "rio", "serve", str(path), "--machine", "robot"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, stdin=subprocess.DEVNULL,
                            env={**os.environ, "RIO_DEBUG": "0", "COLUMNS": "200"})
    seen: list[str] = []
    reader = threading.Thread(target=lambda: seen.extend(proc.stdout), daemon=True)
    reader.start()
    try:
        deadline = time.monotonic() + 90
        while proc.poll() is None and not any(ln.startswith("serving arm") for ln in seen):
            assert time.monotonic() < deadline, "".join(seen)
            time.sleep(0.1)
        _servers, clients, _env = make_station(str(path))  # the loop's side: it reaches the arm at its address
        with clients["arm"]() as arm:
            arm.move_joints(arm.get_state()["joint_pos"])  # the first command: the fake's `fail` clock starts
            if fail != "error":
                time.sleep(2.0)  # serving, long past fail_after_s
                proc.send_signal(signal.SIGINT)
            proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
        reader.join(10)
    out = "".join(seen)
    want = {None: 130, "error": EXIT_NODE_ERROR, "fault": EXIT_FAULT, "stop": EXIT_SAFETY_STOP}[fail]
    assert proc.returncode == want, out
    lines = out.splitlines()
    head = [i for i, ln in enumerate(lines) if ln.startswith("serve on 'exit-serve-")]
    assert len(head) == 1, out
    label = {None: "", "error": "  ERROR: node 'arm'", "fault": "  FAULT: node 'arm'",
             "stop": "  SAFETY STOP: node 'arm'"}[fail]
    if fail:
        assert lines[head[0] + 1].startswith(label), out
    else:
        assert lines[head[0]].endswith(": stopped by SIGINT"), out
    assert "Traceback" not in out, out


def test_a_lost_device_is_an_expected_error_whose_traceback_goes_to_the_debug_log(caplog, monkeypatch):
    """An OSError out of a driver (a serial port unplugged, a connection reset) is a device lost, not a bug:
    one ERROR line naming the node; the traceback only at DEBUG (and on the console under --debug)."""
    import logging

    from rio.runtime.manager import _log_node_error

    monkeypatch.setenv("RIO_DEBUG", "0")
    with caplog.at_level(logging.DEBUG, logger="rio.runtime.manager"):
        try:
            raise ConnectionResetError(104, "Connection reset by peer")
        except OSError as e:
            _log_node_error("arm", e, after_start=True)
    (line, trace) = caplog.records
    assert line.levelno == logging.ERROR and line.exc_info is None
    assert line.getMessage() == "node 'arm' stopped with an error: ConnectionResetError: [Errno 104] Connection " \
                                "reset by peer"
    assert trace.levelno == logging.DEBUG and trace.exc_info is not None
