"""Actions bounded in task space (rio.control.workspace), in the commander, for every workflow alike: a policy
gone wild (x = 10^6 m) or drifting (5 m further every chunk) on a fake arm and on a simulated xArm7 stays in the
arm's workspace box and under its tool speed, and the run's summary counts the clipped commands; a replayed
episode that drifts out is clipped the same way; a joint-space arm with a model keeps its tool in the box through
forward kinematics. Speeds are measured per node cycle (the arm's published-sample counter), not in wall time."""

from __future__ import annotations

import numpy as np
import pytest

from rio.control.commander import JointCommander, PoseCommander
from rio.control.workspace import ToolBound, Workspace
from rio.station import parse_station
from rio.workflows.deploy import run_deploy

WILD = "rio.policy.testing:WildPolicyNode,chunk=10"


# -- the commanders ---------------------------------------------------------------------------------------
def planar_fk(q: np.ndarray) -> np.ndarray:
    """A planar two-link arm (links of 0.5 m) in the x-z plane: the tool position."""
    a, b = q[0], q[0] + q[1]
    return np.array([0.5 * np.cos(a) + 0.5 * np.cos(b), 0.0, 0.5 * np.sin(a) + 0.5 * np.sin(b)])


def joint_commander(ws: Workspace) -> JointCommander:
    c = JointCommander([-3.0, -3.0], [3.0, 3.0], 0.5, 0.5, tool=ToolBound(planar_fk, ws))
    c.reset([0.0, 0.5], t=0.0)
    return c


def test_a_joint_target_whose_tool_leaves_the_box_is_cut_at_its_edge():
    ws = Workspace([-1, -1, 0.3], [1, 1, 1], max_step_m=10.0)  # a table at z = 0.3 (the tool starts at 0.24 + ...)
    c = joint_commander(ws)
    start = planar_fk(c.goal)
    c.reset([0.6, 0.0], t=0.0)  # tool at z = 0.56: inside
    assert planar_fk(c.goal)[2] > 0.3 > start[2]
    c.command([-1.0, 0.0], t_target=0.0, now=0.0)  # straight down through the table
    assert c.clipped == 1
    for k in range(30):
        c.step(0.01 * (k + 1))
    z = planar_fk(c.goal)[2]
    assert 0.3 - 0.002 - 1e-6 <= z < 0.31, z  # at the table's edge (within the bound's slack), held there


def test_joint_goals_move_the_tool_at_most_its_step_per_cycle():
    ws = Workspace([-2, -2, -2], [2, 2, 2], max_step_m=0.01)
    c = joint_commander(ws)
    c.command([1.5, -1.0], t_target=0.0, now=0.0)
    p = [planar_fk(c.goal)]
    for k in range(200):
        p.append(planar_fk(c.step(0.01 * (k + 1))))
    travel = np.linalg.norm(np.diff(np.array(p), axis=0), axis=1)
    assert travel.max() <= 0.01 * 1.02, travel.max()  # the tool step (first-order scaling: within 2 %)
    assert np.allclose(c.goal, [1.5, -1.0], atol=1e-6)  # and it gets there


def test_a_tool_outside_the_box_is_never_yanked_in_and_may_move_back():
    ws = Workspace([-1, -1, 0.3], [1, 1, 1], max_step_m=10.0)
    c = joint_commander(ws)  # the tool starts below the table (z 0.24): where the arm was when enabled
    held = c.goal.copy()
    assert np.allclose(c.step(0.01), held)
    c.command([-0.5, 0.5], t_target=0.0, now=0.01)  # further down: refused, it holds
    assert np.allclose(c.step(0.02), held) and c.clipped == 1
    c.command([0.8, 0.0], t_target=0.0, now=0.03)  # back up into the box: allowed
    for k in range(20):
        c.step(0.04 + 0.01 * k)
    assert planar_fk(c.goal)[2] > 0.3


def test_a_pose_outside_the_box_is_held_where_it_is_and_targets_are_clipped():
    c = PoseCommander([-0.5, -0.5, 0.0], [0.5, 0.5, 0.5], 0.01, 0.05, 0.5)
    c.reset([0.9, 0.0, 0.2, 1.0, 0.0, 0.0, 0.0], t=0.0)  # enabled outside the box
    assert c.step(0.01)[0] == pytest.approx(0.9)  # not yanked to x = 0.5
    c.command([1e6, 0.0, 0.2, 1.0, 0.0, 0.0, 0.0], t_target=0.0, now=0.02)
    xs = [c.step(0.03 + 0.01 * k)[0] for k in range(60)]
    assert c.clipped == 1 and xs[-1] == pytest.approx(0.5) and max(np.abs(np.diff(xs))) <= 0.01 + 1e-12


# -- workflows: a policy gone wild, a drifting one, a replay --------------------------------------------------
def fake_station(**arm):
    comps = {"arm": {"driver": "rio.fake_arm", "dof": 3, "rate_hz": 100.0, **arm}}
    return parse_station({"name": "wild", "rate_hz": 30, "middleware": {"name": "thread"},
                          "embodiment": {"action_space": "eef_pose"}, "components": comps})


class Watch:
    """At every tick, the arm's newest measured tool position and that sample's index (its published count)."""

    def __init__(self):
        self.tools, self.counts, self.box = [], [], None

    def __call__(self, tick):
        arm = tick.env.robot.clients["arm"]
        if self.box is None:
            self.box = arm.workspace()
        while True:  # the newest sample and its index, read together: the count did not move across the read
            count = arm.published()
            tool = np.asarray(arm.get_state()["eef_pose"], dtype=float)[:3].copy()
            if arm.published() == count:
                break
        self.tools.append(tool)
        self.counts.append(count)

    def check(self, tol_m: float = 0.0, lag_cycles: int = 0) -> np.ndarray:
        """The tool stayed in the box; between two ticks it moved at most one tool step per node cycle, plus
        `lag_cycles` steps a measured pose may catch up at once (a simulator's physics, stalled by a loaded
        machine while the goal moved on, seen at load 8)."""
        tools = np.array(self.tools)
        lower, upper = np.array(self.box["lower"]), np.array(self.box["upper"])
        assert (tools >= lower - tol_m).all() and (tools <= upper + tol_m).all(), (tools.min(0), tools.max(0))
        travel = np.linalg.norm(np.diff(tools, axis=0), axis=1)
        cycles = np.diff(np.array(self.counts)) + 1 + lag_cycles  # +1: a measured pose may trail its goal a cycle
        assert (travel <= cycles * self.box["max_tool_step_m"] * 1.05 + tol_m).all(), \
            (travel / cycles).max()
        return tools


@pytest.mark.parametrize("spec", ["value=1e6", "drift=5"])
def test_a_wild_policy_on_a_fake_arm_stays_in_the_box(spec):
    watch = Watch()
    summary = run_deploy(fake_station(), f"{WILD},{spec}", duration=3.0, on_tick=watch, log=None)
    assert watch.box["source"] == "station" and watch.box["upper"] == [1.0, 1.0, 1.0]  # the fake's default box
    assert watch.box["max_tool_step_m"] == pytest.approx(0.01)  # 1 m/s at 100 Hz
    tools = watch.check()
    assert tools[-1][0] == pytest.approx(1.0, abs=1e-6)  # clipped to the box's edge and held there
    (arm,) = summary.arms
    assert arm.clipped is not None and arm.clipped >= 0.9 * arm.commands > 50, (arm.clipped, arm.commands)
    assert f"{arm.clipped} of {arm.commands} commands clipped to its workspace" in summary.format()
    assert any("clipped to it" in w for w in summary.warnings)


sim = pytest.importorskip  # (the sim case needs rio-sim and MuJoCo)


@pytest.mark.parametrize("spec", ["value=1e6", "drift=5"])
def test_a_wild_policy_on_a_sim_arm_stays_in_its_reach_and_a_station_box(spec):
    sim("rio_sim")
    sim("mujoco")
    st = {"name": "wild-sim", "rate_hz": 30, "middleware": {"name": "thread"},
          "embodiment": {"action_space": "eef_pose"},
          "components": {"world_sensor": {"driver": "sim.world", "scene": "xarm7"},
                         "arm": {"driver": "sim.arm", "robot": "xarm7"}}}
    watch = Watch()
    summary = run_deploy(parse_station(st), f"{WILD},{spec}", duration=3.0, on_tick=watch, log=None)
    assert watch.box["source"] == "model" and 0.8 < watch.box["upper"][0] < 1.1, watch.box  # the xArm7's reach
    watch.check(tol_m=0.01, lag_cycles=10)  # the sim's tracking lags the goal a little, its physics up to 0.1 s
    assert summary.arms[0].clipped >= 0.9 * summary.arms[0].commands
    # a station's own box, narrower than the reach (a wall at x = 0.5)
    st["components"]["arm"]["workspace"] = [[-0.6, -0.6, 0.0], [0.5, 0.6, 0.8]]
    watch = Watch()
    summary = run_deploy(parse_station(st), f"{WILD},{spec}", duration=3.0, on_tick=watch, log=None)
    tools = watch.check(tol_m=0.01, lag_cycles=10)
    assert tools[:, 0].max() > 0.45  # it went to the wall ...
    assert summary.arms[0].clipped >= 0.9 * summary.arms[0].commands  # ... and no further


def test_a_joint_space_arm_with_a_model_keeps_its_tool_in_the_box():
    """Joint actions on an arm that ships a model: forward kinematics bounds where the tool goes (a table at
    z = 0.15 m under a tool that starts at 0.205 m; the policy pushes the shoulder forward, down through it)."""
    pytest.importorskip("mink")
    st = parse_station({"name": "wild-joints", "rate_hz": 30, "middleware": {"name": "thread"},
                        "components": {"arm": {"driver": "rio.fake_model_arm", "rate_hz": 100.0,
                                               "workspace": [[-1, -1, 0.15], [1, 1, 1]]}}})
    watch = Watch()
    summary = run_deploy(st, f"{WILD},value=2.0,index=1", duration=3.0, on_tick=watch, log=None)
    tools = watch.check(tol_m=0.002 + 1e-6)  # the bound's slack
    assert tools[:, 2].min() < 0.16  # down to the table ...
    assert summary.arms[0].clipped >= 1  # ... the wild target cut there


def test_a_replayed_episode_that_drifts_out_is_clipped_too(tmp_path):
    """Replay goes through the same commander: an episode whose tool target runs out to x = 5 m."""
    from rio import clock
    from rio.recording import Recorder
    from rio.schema import SingleArmObs, Step
    from rio.workflows.replay import replay_episode

    root = tmp_path / "drift"
    with Recorder(root, fps=30) as rec:
        rec.info["embodiment"] = "single_arm"
        t0 = clock.now()
        for k in range(60):
            pose = np.array([k * 5.0 / 59, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
            obs = SingleArmObs(proprio=pose.copy(), proprio_eef=pose.copy())
            rec.add(Step(k, obs, None, pose, {"t_obs": t0 + k / 30}))
        rec.keep()
    watch = Watch()
    summary = replay_episode(str(root), 0, fake_station(), on_tick=watch, log=None, approach_s=0.2)
    watch.check()
    assert watch.tools[-1][0] == pytest.approx(1.0, abs=1e-6)
    assert summary.arms[0].clipped > 0
