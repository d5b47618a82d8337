"""The scripted expert's episodes without a station, faster than real time: one process steps the scene's
physics tick by tick and plays the part of every node in between, as `rio teleop --teleop expert` chains
them, so its success rate over many seeds is measured in seconds instead of minutes.

Each control tick (the station's rate): the expert's plans read the world (`rio_sim.expert.WorldReader`)
-> the twist teleop's path (`LowPassFilter.over` at 8 Hz, `make_teleop_eef_cmd` in translation_rotation
mode at 0.15 m/s and 1 rad/s, the shared IK warm-started, its target pulled back past 3 cm) -> the arm's
joint goal and the fingers' opening, sent one tick late (the loop's lead) and interpolated over the next
tick by the physics, as the world does with the arm nodes' timed targets. What it leaves out is timing
noise: a loaded machine's late ticks, which the loop and the integrating plans absorb.

    result = expert_rollout("so100", task, seed=0, episode=3)
    result.success, result.time_s

`on_tick` sees every tick's state and the commands decided on it: `rio_sim.expert_demos` records the episodes
as a dataset from there.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .expert import HOLD_S, WorldReader
from .expert_plan import ArmPlan

#: The twist teleop's defaults (rio teleop): low-pass cutoff, speed limits, IK target lead.
FILTER_HZ, MAX_POS_SPEED, MAX_ROT_SPEED, MAX_TARGET_LEAD_M = 8.0, 0.15, 1.0, 0.03


@dataclass
class Rollout:
    success: bool
    time_s: float           # simulated time the episode took (to the expert's verdict, or the time limit)
    phases: list[str] = field(default_factory=list)
    attempts: list[int] = field(default_factory=list)
    #: (ticks, action) the command decided at each tick, on that tick's state (`rio_sim.expert_demos` fills it in)
    commands: np.ndarray | None = None


#: `on_tick(data, placed, goals)`: the world (`mujoco.MjData`, read only) at a tick, whether the task's predicate
#: holds, and each arm's (joint goal, finger opening) decided on that state.
OnTick = Callable[[Any, bool, list[tuple[np.ndarray, float]]], None]


def expert_rollout(scene_name: str, task: Any, seed: int, episode: int, rate_hz: float = 30.0,
                   on_tick: OnTick | None = None) -> Rollout:
    """Run episode `episode` of a run seeded `seed` of `task` (a `rio_sim.task.TaskConfig`) on scene
    `scene_name` with the expert, until it says keep (success held `HOLD_S`) or the time limit passes.
    `on_tick` is called at every tick but the last (see `OnTick`)."""
    import mujoco

    from rio.control.filters import LowPassFilter
    from rio.control.teleop import TeleopMode, make_teleop_eef_cmd
    from rio.kinematics import solver_from_description

    from .indices import arm_indices
    from .robots import get_robot
    from .scenes import build_model, get_scene
    from .task import sample_start

    scene = get_scene(scene_name)
    model = build_model(scene_name)
    data = mujoco.MjData(model)
    reader = WorldReader(model, scene)
    arms = []
    for name in reader.arms:
        robot = get_robot(scene.arm(name).robot)
        idx = arm_indices(model, name, robot)
        data.qpos[idx.qpos] = data.ctrl[idx.act] = robot.home
        data.qpos[idx.finger_qpos] = data.ctrl[idx.finger_act] = robot.max_width / len(robot.finger_joints)
        ik = solver_from_description({"format": "mjcf", "xml": robot.xml(), "frame": robot.tool_site,
                                      "frame_type": "site", "joints": list(robot.arm_joints)},
                                     orientation_cost=1.0 if robot.dof >= 6 else 0.1, damping=1e-4)
        q = np.asarray(robot.home, dtype=np.float64)
        arms.append({"robot": robot, "idx": idx, "ik": ik, "q": q, "target": ik.fk(q),
                     "filter": LowPassFilter(FILTER_HZ), "sent": (q.copy(), robot.max_width)})
    for name, pose in sample_start(task, scene, seed, episode).poses.items():
        j = model.joint(name)
        data.qpos[j.qposadr[0]:j.qposadr[0] + 7] = pose
    mujoco.mj_forward(model, data)
    plans = [ArmPlan() for _ in arms]
    dt, ts = 1.0 / rate_hz, model.opt.timestep
    tick = 0  # tick k ends at the physics step nearest k * dt: ticks on the loop's grid, not a rounded period's
    t_success = None
    while data.time < task.time_limit_s:
        views = reader.views(data.time, data.qpos, data.qvel)
        placed = all(v.placed for v in views)
        t_success = (t_success if t_success is not None else data.time) if placed else None
        if t_success is not None and data.time - t_success >= HOLD_S:
            return Rollout(True, float(data.time), [p.phase for p in plans], [p.attempts for p in plans])
        goals = []
        for i, (a, plan, view) in enumerate(zip(arms, plans, views, strict=True)):
            twist, grip = plan.step(view)
            twist = a["filter"].over(reader.to_base(i, twist), dt)
            a["target"] = make_teleop_eef_cmd(a["target"], twist, dt, TeleopMode.TRANSLATION_ROTATION, MAX_POS_SPEED,
                                              MAX_ROT_SPEED)
            res = a["ik"].solve(a["target"], a["q"], max_iters=10)
            a["q"] = res.q
            if res.pos_err > MAX_TARGET_LEAD_M:
                a["target"] = np.concatenate([a["ik"].fk(res.q)[:3], a["target"][3:]])
            goals.append((res.q.copy(), grip * a["robot"].max_width))
        if on_tick is not None:
            on_tick(data, placed, goals)
        # last tick's goals reach the actuators now, each interpolated over this tick (the loop's lead)
        starts = [(data.ctrl[a["idx"].act].copy(), data.ctrl[a["idx"].finger_act].copy()) for a in arms]
        tick += 1
        steps = max(1, round(tick * dt / ts) - round((tick - 1) * dt / ts))
        for k in range(1, steps + 1):
            f = k / steps
            for a, (q0, w0) in zip(arms, starts, strict=True):
                q, width = a["sent"]
                data.ctrl[a["idx"].act] = q0 + f * (q - q0)
                n = len(a["idx"].finger_act)
                data.ctrl[a["idx"].finger_act] = w0 + f * (np.full(n, width / n) - w0)
            mujoco.mj_step(model, data)
        for a, goal in zip(arms, goals, strict=True):
            a["sent"] = goal
    return Rollout(False, float(data.time), [p.phase for p in plans], [p.attempts for p in plans])
