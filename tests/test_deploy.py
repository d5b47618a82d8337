"""`rio deploy` end to end: known ramps through the policy node, a recorded rollout replayed, and a
policy process that crashes while the robot holds."""

from __future__ import annotations

import numpy as np
import pytest

from rio.policy import AsyncConfig
from rio.station import parse_station
from rio.workflows.deploy import run_deploy

RAMP = "rio.policy.testing:RampPolicyNode"


def station(mw: str = "thread", camera: bool = True):
    comps = {"arm": {"driver": "rio.fake_arm", "dof": 3, "rate_hz": 200.0},
             "gripper": {"driver": "rio.fake_gripper", "rate_hz": 200.0}}
    if camera:
        comps["front_camera"] = {"driver": "rio.fake_camera", "width": 32, "height": 24}
    return parse_station({"name": "deploytest", "rate_hz": 50, "middleware": {"name": mw}, "components": comps})


def test_ramp_policy_gives_the_ramp_command_stream():
    ticks = []
    summary = run_deploy(station(), f"{RAMP},slope=0.5,chunk=10,rate_hz=50,forward_s=0.03", duration=1.2,
                         config=AsyncConfig(request_threshold=0.6, blend="crossfade", crossfade_s=0.06),
                         on_tick=ticks.append, log=None)
    assert summary.reason == "duration reached", summary.reason
    used = [k for k in ticks if k.info["sample"] is not None]
    assert summary.details["stats"]["chunks"] >= 5 and len(used) > 30
    first = min(used, key=lambda k: k.info["sample"].seq)
    t0, start = first.info["sample"].t_obs, None
    for k in ticks:
        if k.step.meta["t_obs"] <= t0 + 1e-9 and k.info["sample"] is None:
            start = k.step.observation.proprio  # the observation the first chunk was computed from
    assert start is not None
    late = [k for k in used if k.info["sample"].late]
    for k in used:
        ramp = start + 0.5 * (k.t_target - t0)
        if k.info["sample"].late:  # a chunk came late (a loaded machine): the command holds, behind the line
            assert (k.action <= ramp + 1e-9).all(), (k.action, ramp)
        else:
            np.testing.assert_allclose(k.action, ramp, atol=1e-9)
    assert len(late) < len(used) / 2 and summary.details["stats"]["late_ticks"] == len(late), \
        (len(late), summary.format())
    assert summary.details["stats"]["first_action_ms_p50"] >= 30.0


def test_replay_reproduces_a_recorded_rollout(tmp_path):
    rec_dir = tmp_path / "rollouts"
    recorded = []
    run_deploy(station(), f"{RAMP},slope=0.4,chunk=25,rate_hz=50,forward_s=0.02", duration=1.0,
               record=str(rec_dir), on_tick=recorded.append, log=None,
               config=AsyncConfig(request_threshold=0.5))
    replayed = []
    summary = run_deploy(station(), f"replay.episode,episode={rec_dir},chunk=20", duration=1.0,
                         on_tick=replayed.append, log=None, config=AsyncConfig(request_threshold=0.5))
    assert summary.details["metadata"]["extra"]["steps"] == len(recorded)
    # the recorded commands as a function of time since the recording's first step
    r0 = recorded[0].step.meta["t_obs"]
    rt = np.array([k.t_target - r0 for k in recorded])
    ra = np.array([k.action for k in recorded])
    p0 = min(k.info["sample"].t_obs for k in replayed if k.info["sample"] is not None)  # replay's clock origin
    errors = []
    for k in replayed:
        s = k.t_target - p0
        if k.info["sample"] is None or not rt[0] + 0.05 < s < rt[-1] - 0.05:
            continue
        want = np.array([np.interp(s, rt, col) for col in ra.T])
        errors.append(np.abs(k.action - want).max())
    assert len(errors) > 25
    # exact between the recorded knots; where the recording turned (a new chunk), replay's knots lie off by
    # the difference of the two runs' observation times from their ticks (wake-up jitter): small, and bounded
    # by the motion of one control period
    assert np.median(errors) < 1e-6 and max(errors) < 0.4 * 0.02, (np.median(errors), max(errors))
    # and the robot went where it went when recorded
    q_rec = np.array([k.step.observation.proprio for k in recorded])
    q_rep = np.array([k.step.observation.proprio for k in replayed])
    t_rec = np.array([k.step.meta["t_obs"] - r0 for k in recorded])
    t_rep = np.array([k.step.meta["t_obs"] - p0 for k in replayed])
    mid = (t_rep > 0.2) & (t_rep < min(t_rec[-1], t_rep[-1]) - 0.1)
    # until a chunk came late, if one did: the replay then held its last command (a loaded machine's stall
    # in the policy node, seen in CI at load 10), which the recording did not
    late = [i for i, k in enumerate(replayed) if k.info["sample"] is not None and k.info["sample"].late]
    if late:
        mid &= t_rep < t_rep[late[0]]
    assert mid.sum() >= 5, (late, summary.format())
    # typically within two control periods of motion. Either run's fake arm may have been descheduled for a
    # moment (tens of ms at load 8, 0.27 s in CI, the arm then catching up at its speed limit), which puts the
    # two runs' positions off in time, not off the path: compare each replayed position with the recording
    # at the nearest time within 0.3 s, so a stall reads as a lag. An arm that does not follow the replayed
    # commands still fails (it falls more than 0.3 s of the ramp behind, or leaves it); the commands
    # themselves were compared exactly above
    lags = np.arange(-0.3, 0.3001, 0.01)
    err = np.full((len(lags), int(mid.sum())), np.inf)
    for i, lag in enumerate(lags):
        ref = np.stack([np.interp(t_rep[mid] - lag, t_rec, q_rec[:, j]) for j in range(q_rec.shape[1])], axis=1)
        err[i] = np.abs(q_rep[mid] - ref).max(axis=1)
    best = err.min(axis=0)
    assert np.median(best) < 0.4 * 0.04 and np.quantile(best, 0.9) < 0.4 * 0.04, (best, summary.format())


def test_crashing_policy_is_reported_by_name_and_the_robot_holds():
    from rio.fakes.arms import FakeArm  # noqa: F401  (process middleware imports it by name)

    ticks = []
    summary = run_deploy(station("shm", camera=False), "rio.policy.testing:CrashPolicyNode,crash_after=2,"
                         "forward_s=0.02,chunk=10", duration=20.0, on_tick=ticks.append, log=None,
                         config=AsyncConfig(request_threshold=1.0))
    assert "node 'policy' stopped" in summary.reason and "holds" in summary.reason
    assert summary.seconds < 10.0
    assert summary.details["stats"]["chunks"] == 2
    np.testing.assert_allclose(summary.details["held"], ticks[-1].action)


def test_unknown_policy_names_the_registered_ones():
    from rio.errors import ConfigError

    with pytest.raises(ConfigError, match="replay.episode"):
        run_deploy(station(), "replay.episod", duration=0.1, log=None)


def test_rio_deploy_command_and_benchmark_smoke(tmp_path, capsys):
    import json

    from rio.benchmarks.obs_to_action import main as bench_main
    from rio.cli import main

    toml = tmp_path / "st.toml"
    toml.write_text('name = "clitest"\nrate_hz = 50\n[middleware]\nname = "thread"\n'
                    '[components.arm]\ndriver = "rio.fake_arm"\ndof = 2\n')
    assert main(["deploy", str(toml), "--policy", "rio.policy.testing:SleepPolicyNode,forward_s=0.01,chunk=5",
                 "--duration", "0.5", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["reason"] == "duration reached" and out["details"]["stats"]["chunks"] >= 3
    assert bench_main(["--seconds", "1", "--cameras", "1", "--width", "64", "--height", "48",
                       "--middleware", "thread", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    for key in ("first_action_ms_p50", "first_action_ms_p99", "action_age_ms_p50", "overhead_ms_p50",
                "loop_jitter_us_p99", "reference_lerobot_0_4_4", "ratio_lerobot_over_rio"):
        assert res[key] is not None, key


def test_station_policy_component_is_inert_until_deployed(tmp_path):
    from rio.runtime.manager import ServerManager
    from rio.station import make_station

    t = np.arange(40) / 50.0
    np.savez(tmp_path / "ep.npz", action=np.stack([np.sin(t), np.cos(t)], axis=1), t=t)
    data = {"name": "withpolicy", "rate_hz": 50, "middleware": {"name": "thread"},
            "components": {"arm": {"driver": "rio.fake_arm", "dof": 2},
                           "policy": {"driver": "replay.episode", "episode": str(tmp_path / "ep.npz")}}}
    servers, _clients, _env = make_station(parse_station(data))
    with ServerManager(servers, station="withpolicy"):  # loads nothing: no observation layout yet
        pass
    ticks = []
    summary = run_deploy(parse_station(data), duration=0.5, on_tick=ticks.append, log=None)
    assert summary.details["policy"] == "replay.episode" and summary.details["stats"]["chunks"] >= 1
    assert summary.details["metadata"]["dt"] == pytest.approx(0.02)


def test_a_policy_gets_the_rate_it_is_given():
    """`rate_hz` is a field of the policy node (its loop's, unused: it runs on requests) and of most policies
    (their actions' rate): the policy gets it. The node's field used to swallow it (`onnx.local,rate_hz=30`
    ran its chunks at the default 50 Hz)."""
    summary = run_deploy(station(), "rio.policy.testing:SleepPolicyNode,chunk=5,rate_hz=25", duration=0.3, log=None)
    assert summary.details["metadata"]["dt"] == pytest.approx(1 / 25)
