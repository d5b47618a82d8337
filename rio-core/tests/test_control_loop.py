"""The one control loop (rio.loop.control_loop) through the command line, as users run it: a user's own
controller (`rio run --controller`, the docs/controllers.md example verbatim), the summary's tracking
(an arm that ignores its commands is reported and the command exits 3), and SIGINT / SIGTERM / SIGHUP
ending teleop, deploy, replay and run through their normal end: summary printed, exit status
128 + signal, the recording kept, no shared memory left behind. Fake arms, real processes."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

DOCS = Path(__file__).resolve().parents[2] / "docs" / "controllers.md"

JOINT_STATION = """
name = "loop-joints"
rate_hz = 50
[middleware]
name = "{mw}"
[components.arm]
driver = "rio.fake_arm"
dof = 3
frozen = {frozen}
[components.gripper]
driver = "rio.fake_gripper"
"""

EEF_STATION = """
name = "loop-eef"
rate_hz = 50
[middleware]
name = "shm"
[embodiment]
action_space = "eef_pose"
[components.arm]
driver = "rio.fake_arm"
dof = 3
[components.gripper]
driver = "rio.fake_gripper"
[components.teleop]
driver = "teleop.scripted"
script = "square"
"""


def _docs_controller(tmp_path: Path) -> Path:
    """The controller module of docs/controllers.md, as written there."""
    code = re.search(r"```python\n# my_lab/controllers.py\n(.*?)```", DOCS.read_text(), re.S)
    assert code, "docs/controllers.md lost its example"
    pkg = tmp_path / "my_lab"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "controllers.py").write_text(code.group(1))
    return tmp_path


def _env(pythonpath: Path | None = None) -> dict[str, str]:
    env = {**os.environ}
    if pythonpath is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(pythonpath), env.get("PYTHONPATH", "")])
    return env


def _rio(*args: str, env: dict[str, str] | None = None, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "rio", *args], capture_output=True, text=True, timeout=timeout,
                          stdin=subprocess.DEVNULL, env=env)


def test_the_documented_controller_runs_with_rio_run_and_reports_its_tracking(tmp_path):
    path = _docs_controller(tmp_path)
    st = tmp_path / "st.toml"
    st.write_text(JOINT_STATION.format(mw="thread", frozen="false"))
    out = _rio("run", str(st), "--controller", "my_lab.controllers:Wave", "--set", "amplitude=0.2",
               "--duration", "1.5", "--json", env=_env(path))
    assert out.returncode == 0, out.stderr[-3000:]
    s = json.loads(out.stdout)
    assert s["workflow"] == "wave" and s["reason"] == "duration reached" and s["followed"], s
    assert s["ticks"] > 30 and s["lateness_us"]["p99"] >= s["lateness_us"]["p50"] >= 0
    arm = s["arms"][0]
    assert arm["role"] == "arm" and arm["space"] == "joint_pos" and arm["followed"]
    # commanded a sine of 0.2 rad on the last joint; the fake arm follows each command exactly
    assert arm["commanded_joint_path_rad"] > 0.3 and arm["joint_path_rad"] > 0.8 * arm["commanded_joint_path_rad"]
    mx, mean, final = arm["joint_err_rad"]
    assert final < 1e-9 and mean < 0.05, arm["joint_err_rad"]
    assert s["node_rates_hz"]["arm"] > 10


def test_an_arm_that_ignores_its_commands_is_reported_and_the_command_exits_3(tmp_path):
    path = _docs_controller(tmp_path)
    st = tmp_path / "st.toml"
    st.write_text(JOINT_STATION.format(mw="thread", frozen="true"))
    out = _rio("run", str(st), "--controller", "my_lab.controllers:Wave", "--duration", "1", env=_env(path))
    assert out.returncode == 3, (out.stdout, out.stderr[-2000:])
    assert "DID NOT FOLLOW" in out.stdout and "WARNING: arm was commanded" in out.stdout, out.stdout


def test_a_controller_spec_that_is_not_one_is_refused_by_name(tmp_path):
    st = tmp_path / "st.toml"
    st.write_text(JOINT_STATION.format(mw="thread", frozen="false"))
    out = _rio("run", str(st), "--controller", "json:JSONDecoder")
    said = re.sub(r"[│╭╮╰╯─\s]+", " ", out.stderr)  # the words, without the error box typer draws
    assert out.returncode == 2 and "is not a controller: it lacks ['reset', 'step', 'done']" in said, said


def _record_fake_episode(root: Path) -> None:
    from rio import clock
    from rio.recording import Recorder
    from rio.schema import SingleArmObs, Step

    with Recorder(root, fps=50) as rec:
        rec.info["embodiment"] = "single_arm"
        t0 = clock.now()
        for i in range(500):  # 10 s: longer than any test waits
            a = np.array([0.001 * i, 0.0, 0.0, 0.03])
            rec.add(Step(i, SingleArmObs(proprio=a.copy()), None, a, {"t_obs": t0 + i / 50}))
        rec.keep()


def _workflow(name: str, tmp_path: Path) -> tuple[list[str], str, dict[str, str] | None]:
    """(rio arguments, the stderr line that says the loop runs, env) of a workflow on a fake station."""
    joints = tmp_path / "joints.toml"
    joints.write_text(JOINT_STATION.format(mw="shm", frozen="false"))
    if name == "teleop":
        eef = tmp_path / "eef.toml"
        eef.write_text(EEF_STATION)
        return (["teleop", str(eef), "--record", str(tmp_path / "data"), "--on-end", "keep"], "teleop running",
                None)
    if name == "deploy":
        return (["deploy", str(joints), "--policy", "rio.policy.testing:SleepPolicyNode,forward_s=0.02,chunk=10"],
                "control at", None)
    if name == "replay":
        _record_fake_episode(tmp_path / "ep")
        return (["replay", str(tmp_path / "ep"), "--station", str(joints), "--approach", "0.2"], "replaying episode",
                None)
    return (["run", str(joints), "--controller", "my_lab.controllers:Wave"], "starting station",
            _env(_docs_controller(tmp_path)))


def _leftovers(run_ids: set[str]) -> list[str]:
    """Shared-memory objects of these runs still in /dev/shm."""
    names = os.listdir("/dev/shm") if os.path.isdir("/dev/shm") else []
    return [n for n in names if any(f"_{i}_" in n for i in run_ids)]


@pytest.mark.parametrize("workflow, sig", [("teleop", "SIGTERM"), ("teleop", "SIGHUP"), ("teleop", "SIGINT"),
                                           ("deploy", "SIGTERM"), ("replay", "SIGHUP"), ("run", "SIGTERM")])
def test_a_signal_ends_the_workflow_through_its_normal_end(tmp_path, workflow, sig):
    args, running, env = _workflow(workflow, tmp_path)
    # the station's run directories land here (their names carry the run ids); short: it holds unix sockets
    tmp = Path(tempfile.mkdtemp(prefix="rt"))
    env = {**(env or os.environ), "TMPDIR": str(tmp)}
    proc = subprocess.Popen([sys.executable, "-m", "rio", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            stdin=subprocess.DEVNULL, text=True, env=env)
    said = []
    try:
        assert proc.stderr is not None
        for line in proc.stderr:  # the loop is running once it says so
            said.append(line)
            if running in line:
                break
        time.sleep(0.5)
        runs = {p.name.split("-")[1] for p in tmp.glob("rio-*-*") if p.is_dir()}
        proc.send_signal(getattr(signal, sig))
        out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    said.append(err)
    assert proc.returncode == 128 + getattr(signal, sig), ("".join(said)[-3000:], out)
    assert f"stopped by {sig}" in out, out
    if workflow == "teleop":  # the episode in progress was kept, and is whole
        from rio.recording import Dataset

        ep = Dataset(tmp_path / "data").episode(0)
        assert len(ep.column("t")) > 5 and not ep.verify()
        assert "1 episode(s) kept" in out
    assert runs and not _leftovers(runs), ("shared memory left behind", _leftovers(runs))
    assert not list(tmp.glob("rio-*-*")), "run directories left behind"
    tmp.rmdir()


@pytest.mark.slow
def test_a_deploy_profile_has_a_track_per_node_and_loop_phase_and_a_row_per_process(tmp_path):
    pytest.importorskip("matplotlib")
    pytest.importorskip("psutil")
    from rio.profiling import load_trace

    st = tmp_path / "st.toml"
    st.write_text(JOINT_STATION.format(mw="shm", frozen="false"))
    out = _rio("deploy", str(st), "--policy", "rio.policy.testing:SleepPolicyNode,forward_s=0.02,chunk=10",
               "--duration", "1.5", "--profile", str(tmp_path / "prof"))
    assert out.returncode == 0, out.stderr[-3000:]
    trace = load_trace(tmp_path / "prof" / "trace.json")
    names = {(e["pid"], e["tid"]): e["args"]["name"] for e in trace["traceEvents"] if e["name"] == "thread_name"}
    procs = {e["pid"]: e["args"]["name"] for e in trace["traceEvents"] if e["name"] == "process_name"}
    tracks = {(procs[p], t) for (p, _), t in names.items()}
    for node in ("arm", "gripper", "policy"):
        assert (f"node {node}", "read_state") in tracks or (f"node {node}", "request") in tracks, tracks
    spans = {e["name"] for e in trace["traceEvents"] if e["ph"] == "X"}
    assert {"controller", "send action + read state", "policy request", "handle_request"} <= spans, spans
    assert (tmp_path / "prof" / "timeline.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    rows = {r["label"] for r in json.loads((tmp_path / "prof" / "stats.json").read_text())["processes"]}
    assert {"node arm", "node gripper", "node policy"} <= rows, rows
    assert "trace.json" in out.stdout  # the summary says where the profile went


def test_the_loop_sets_the_gil_switch_interval_only_while_it_runs():
    """`gil_switch_s` shortens the interpreter's switch interval for the run (a node thread of the loop's
    process then hands over the GIL within it) and puts the old one back, whatever the loop's end."""
    import sys

    from rio.benchmarks.loop_jitter import Hold, _station
    from rio.loop.control_loop import ControlLoop
    from rio.runtime.manager import ServerManager
    from rio.station import make_station

    before = sys.getswitchinterval()
    seen: list[float] = []
    servers, _clients, env = make_station(_station("thread", 100.0, 0))
    with ServerManager(servers, station="gil-switch"), env:
        s = ControlLoop(env, Hold(), rate_hz=100.0, duration=0.3, settle=False, log=None, gil_switch_s=1e-4,
                        on_tick=lambda _t: seen.append(sys.getswitchinterval())).run()
    assert s.ticks > 5 and seen and all(abs(x - 1e-4) < 1e-9 for x in seen)
    assert sys.getswitchinterval() == before


def test_the_loop_freezes_the_collector_without_a_full_pass(monkeypatch):
    """A full collection walks every object of the process holding the GIL: at the loop's start it stalled
    every thread of the process (a scripted device's script went by unseen, an emulated T1 published no
    state until its driver faulted). The loop collects the young generations only, then freezes."""
    import gc

    from rio.benchmarks.loop_jitter import Hold, _station
    from rio.loop.control_loop import ControlLoop
    from rio.runtime.manager import ServerManager
    from rio.station import make_station

    collected: list[int] = []
    collect = gc.collect

    def spy(generation: int = 2) -> int:
        collected.append(generation)
        return collect(generation)

    servers, _clients, env = make_station(_station("thread", 100.0, 0))
    with ServerManager(servers, station="gc-freeze"), env:
        monkeypatch.setattr(gc, "collect", spy)
        frozen: list[int] = []
        s = ControlLoop(env, Hold(), rate_hz=100.0, duration=0.2, settle=False, log=None,
                        on_tick=lambda _t: frozen.append(gc.get_freeze_count())).run()
        monkeypatch.setattr(gc, "collect", collect)
    # the collector was paused for every tick it ran (ticks a loaded machine skips do not count)
    assert s.ticks > 0 and frozen and min(frozen) > 0
    assert collected and max(collected) < 2, collected  # and no full pass started it
    assert gc.get_freeze_count() == 0
