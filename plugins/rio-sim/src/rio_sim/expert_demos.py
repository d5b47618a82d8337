"""Expert demonstrations recorded faster than real time: `expert_rollout`'s episodes written as a RIO dataset
with the rows `rio teleop STATION --teleop expert --record D` writes, minus the cameras (none are rendered),
in a fraction of a second each instead of the episode's length:

    record_expert_demos("data/demos", "sim-so100", episodes=range(40), seed=0)
    # then: rio export data/demos --format zarr out.zarr; train on state + environment state

Each tick of the rollout becomes the step the control loop records, made by the same code where it can be:
the observation is the station's embodiment's own (`observe()` over stand-in clients that read the rollout's
physics: joints, the arm kind's forward kinematics, the fingers' opening), the world sensor's values are its
object poses, success, task time and time limit, named by the recorder from the sensor's `object_names()`
(the environment state). As in the loop, a row's action is the command decided on the row before it (the
loop sends, then reads), so exports pair observation k with the command decided on it, as they do for a live
recording. Row 0 holds the command the station starts with (home, fingers open). Times are simulated seconds.
Episodes are kept only where the expert succeeded, with the task's verdict in their metadata, as `rio teleop`
keeps them on the expert's word.

It plays what a live station does without its timing noise (`expert_rollout`); a policy trained on it is
deployed and judged on the live station (`rio eval`).
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from .expert_rollout import Rollout, expert_rollout


class _Client:
    """What the embodiment reads of a node: `get_state()` (and an arm's `num_joints()`)."""

    def __init__(self, state: dict[str, Any], dof: int = 0):
        self.state, self.dof = state, dof

    def get_state(self) -> dict[str, Any]:
        return self.state

    def num_joints(self) -> int:
        return self.dof


class _World:
    def __init__(self, names: list[str]):
        self.names = names

    def object_names(self) -> list[str]:
        return list(self.names)


class _Env:
    """What `Recorder.describe_env` reads of an env: station, embodiment, sensors."""

    def __init__(self, station: str, robot: Any, sensors: dict[str, Any]):
        self.station, self.robot, self.sensors = station, robot, sensors


def record_expert_demos(root: str | Path, station: Any = "sim-so100", episodes: Iterable[int] = range(10),
                        seed: int | None = None, keep_failures: bool = False) -> list[Rollout]:
    """Record episode k of a run seeded `seed` (None: the task's own) for each k of `episodes` on `station`'s
    task (a registered name, a .toml path or a `Station`: a single arm with a gripper in joint space, and a sim
    world with a task) into the dataset `root` (created, or appended to). Returns every rollout, each with the
    command decided at each of its ticks (`Rollout.commands`: the ground truth of which command followed which
    observation); only the successful ones are kept unless `keep_failures`."""
    from rio.embodiments.single_arm import SingleArm
    from rio.recording import Recorder
    from rio.station.build import resolve_embodiment
    from rio.station.load import load_station
    from rio.station.roles import kind_of, sensor_name

    from .scenes import get_scene
    from .task import episode_seed

    st = load_station(station)
    worlds = [r for r, c in st.components.items() if kind_of(r) == "sensor" and c.driver == "sim.world"
              and c.config.task is not None]
    if len(worlds) != 1:
        raise ValueError(f"station '{st.name}': expert demonstrations need one sim.world sensor with a task, "
                         f"found {worlds or 'none'}")
    world = st.components[worlds[0]].config
    scene = get_scene(world.scene)
    emb_cls, emb_config = resolve_embodiment(st)
    arm = st.components["arm"].config if "arm" in st.components else None
    if (emb_cls is not SingleArm or "gripper" not in st.components or "hand" in st.components
            or emb_config.action_space != "joint_pos" or [a for a, _, _ in scene.pick_place] != [arm.arm]):
        raise ValueError(f"station '{st.name}': expert demonstrations are recorded for a single arm with a gripper, "
                         "commanded in joint space, the scene's one pick-and-place arm")
    seed = world.task.seed if seed is None else int(seed)
    ticks = _Ticks(scene, arm.robot, arm.arm, sensor_name(worlds[0]), world.task.time_limit_s, emb_config,
                   scene.reported_objects(world.objects))
    out = []
    with Recorder(root, fps=float(st.rate_hz), station=st.name, cameras=False,
                  metadata={"source": "rio_sim.expert_demos"}) as rec:
        rec.describe_env(_Env(st.name, ticks.emb, {ticks.sensor: _World(ticks.names)}))
        for k in episodes:
            ticks.start(rec)
            result = expert_rollout(scene.name, world.task, seed, k, rate_hz=float(st.rate_hz), on_tick=ticks)
            result.commands = np.array(ticks.decided)
            out.append(result)
            rec.annotate(task={"kind": world.task.kind, "time_limit_s": world.task.time_limit_s, "seed": seed,
                               "episode": k, "episode_seed": episode_seed(seed, k), "success": result.success,
                               "time_s": round(result.time_s, 3)})
            if result.success or keep_failures:
                rec.keep(ended_by="the expert said keep" if result.success else "the expert failed")
            else:
                rec.discard()
    return out


class _Ticks:
    """`expert_rollout`'s `on_tick`: each tick as the step a control loop would record (module docstring)."""

    def __init__(self, scene: Any, robot_name: str, arm: str, sensor: str, time_limit_s: float, emb_config: Any,
                 objects: list[str]):
        from rio.embodiments.single_arm import SingleArm
        from rio.kinematics import solver_from_description

        from .arm import robot_description
        from .indices import arm_indices
        from .robots import get_robot
        from .scenes import build_model

        robot = get_robot(robot_name)
        model = build_model(scene.name)
        self.names = objects  # the world node's object_poses rows (`SimWorld.Config.objects`)
        self.qadr = [model.joint(n).qposadr[0] for n in self.names]
        self.idx = arm_indices(model, arm, robot)
        dof = len(robot.arm_joints)
        # forward kinematics made as the arm kind makes it from sim.arm's description (rio.interfaces.arm)
        self.fk = solver_from_description(robot_description(robot), orientation_cost=1.0 if dof >= 6 else 0.1,
                                          damping=1e-4).fk
        self.start_command = np.concatenate([robot.home, [robot.max_width]])  # home, fingers open
        self.arm_state: dict[str, Any] = {}
        self.grip_state: dict[str, Any] = {}
        self.emb = SingleArm({"arm": _Client(self.arm_state, dof), "gripper": _Client(self.grip_state)}, emb_config)
        self.sensor, self.time_limit_s = sensor, time_limit_s
        self.rec: Any = None

    def start(self, rec: Any) -> None:
        self.rec, self.sent, self.t0, self.k = rec, self.start_command.copy(), None, 0
        self.decided: list[np.ndarray] = []

    def __call__(self, data: Any, placed: bool, goals: list[tuple[np.ndarray, float]]) -> None:
        from rio.schema import Step

        t = float(data.time)
        self.t0 = t if self.t0 is None else self.t0
        q = np.array(data.qpos[self.idx.qpos])
        self.arm_state.update(joint_pos=q, joint_vel=np.array(data.qvel[self.idx.dof]), eef_pose=self.fk(q),
                              timestamp=t)
        self.grip_state.update(width=float(np.sum(data.qpos[self.idx.finger_qpos])), timestamp=t)
        task_time = t - self.t0
        world = {"sim_time": t, "object_poses": np.stack([np.array(data.qpos[a:a + 7]) for a in self.qadr]),
                 "success": bool(placed), "task_time": task_time, "time_up": task_time >= self.time_limit_s}
        meta = {"sensors": {self.sensor: world}, "t_obs": t,
                "timestamps": {"arm": t, "gripper": t, f"{self.sensor}_sensor": t}}
        self.rec.add(Step(self.k, self.emb.observe(), None, self.sent, meta))
        self.k += 1
        q_goal, width = goals[0]
        self.sent = np.concatenate([q_goal, [width]])  # the command decided now: the next row's action
        self.decided.append(self.sent)
