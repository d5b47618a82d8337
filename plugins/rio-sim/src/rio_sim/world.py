"""`sim.world`: the node that owns a station's physics.

It compiles the scene, puts every arm at home, and then, each tick, picks up new actuator targets
from the world bus, advances physics to the current wall-clock time (interpolating each actuator
towards its target time, step by step) and writes the new state back to the bus for the arm,
gripper and camera nodes. Through the middleware it publishes what no other node measures: the
simulated time, the real-time factor and the pose of every free object (ground truth for tests,
privileged observations and success checks).

A humanoid scene's world also applies the servo gains its humanoid and hand nodes configure (through
the bus) to its own copy of the model, and with `mounted = false` compiles the scene's free-floating
variant (every node follows: they compile what the bus names).

If the machine cannot keep up, at most `max_steps_per_tick` physics steps run per tick and the rest
of the lag is dropped: simulated time then runs slower than wall time (`rtf` < 1) instead of the
physics spiralling behind.

With a `task` (`rio_sim.task`) the world also runs episodes: `start_episode(seed, episode)` (what
`Env.reset` calls on every sensor that offers it) puts the objects at that episode's drawn start, and
every sample carries `success` (`rio_sim.success`: every cube on its pad, released), `task_time` (simulated
seconds since the episode started) and `time_up` (the task's time limit has passed). The station opens
at episode 0's start.
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
from pydantic import Field, ValidationInfo, field_validator, model_validator

from rio import clock
from rio.control.interpolators import LinearInterpolator
from rio.runtime.node import Node, NodeConfig, client_side, remote

from .bus import WorldBus
from .indices import arm_indices, joint_indices
from .robots import get_robot
from .scenes import SCENES, get_scene, scene_key
from .task import TaskConfig, check_task, sample_start


class SimWorld(Node):
    client_state = ("objects",)

    class Config(NodeConfig):
        scene: str = Field("so100", description=f"packaged scene: {', '.join(SCENES)}")
        world: str = Field("sim", description="name the station's sim nodes use to find this world")
        rate_hz: float = Field(250.0, gt=0, description="physics batches per second (state published at this rate)")
        max_steps_per_tick: int = Field(20, ge=1, description="physics steps per tick at most (then time slows)")
        mounted: bool = Field(True, description="humanoid scenes: the pelvis welded to a stand at standing height "
                                                "(upper-body work without a balance controller); false: a free-"
                                                "floating base, which falls without a locomotion policy")
        task: TaskConfig | None = Field(None, description="episodes with randomized starts, success and a time "
                                                          "limit (see rio_sim.task)")
        objects: list[str] | None = Field(None, description="the free objects whose poses object_poses reports "
                                                            "(and a recording's environment state holds), in this "
                                                            "order; default: all of the scene's. A state-based "
                                                            "policy learns better without distractors' poses")

        @field_validator("objects")
        @classmethod
        def _objects_of_scene(cls, objects: list[str] | None, info: ValidationInfo) -> list[str] | None:
            if objects is not None and info.data.get("scene") in SCENES:
                get_scene(info.data["scene"]).reported_objects(objects)
            return objects

        @model_validator(mode="after")
        def _task_fits_scene(self):
            if self.task is not None:
                check_task(self.task, get_scene(self.scene))
            return self

    def setup(self) -> None:
        c = self.config
        self.scene_name, self.world, self.max_steps = scene_key(c.scene, c.mounted), c.world, int(c.max_steps_per_tick)
        self.scene = get_scene(self.scene_name)
        self.objects = self.scene.reported_objects(c.objects)
        n = max(len(self.objects), 1)
        self.example_data = {"sim_time": 0.0, "rtf": 1.0, "object_poses": np.zeros((n, 7))}
        self.task = c.task
        if self.task is not None:
            self.example_data.update(success=False, task_time=0.0, time_up=False)
        self.model = self.data = self.bus = None
        self.judge = None
        self._t_episode = 0.0

    @client_side
    def object_names(self) -> list[str]:
        """Names of the rows of `object_poses`."""
        return list(self.objects)

    # -- lifecycle ------------------------------------------------------------------------------
    def open(self) -> None:
        import mujoco

        from .scenes import build_model

        self._mj = mujoco
        self.model = copy.deepcopy(build_model(self.scene_name))  # its own: servo gains change on it
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._obj_qadr = np.array([m.joint(o).qposadr[0] for o in self.objects], dtype=int)
        self._home()
        self.bus = WorldBus.create(self.world, self.scene_name, m.nq, m.nv, m.nu, m.nsensordata)
        self._seen, self._gains_seen = self.bus.cmd_stamp.copy(), self.bus.gain_stamp.copy()
        if self.task is not None:
            from .success import PickPlaceJudge

            self.judge = PickPlaceJudge(m, self.scene)
            self._start(self.task.seed, 0)
        self.bus.write_state(self.data.time, self.data.qpos, self.data.qvel, self.data.ctrl, self.data.sensordata)
        self.bus.mark_ready()

    def close(self) -> None:
        if self.bus is not None:
            self.bus.close()
            self.bus = None

    def _home(self) -> None:
        """Initial state: objects where the scene puts them, arms at home, grippers open."""
        mj, m, d = self._mj, self.model, self.data
        mj.mj_resetData(m, d)
        for arm in self.scene.arms:
            robot = get_robot(arm.robot)
            idx = arm_indices(m, arm.name, robot)
            d.qpos[idx.qpos] = robot.home
            d.ctrl[idx.act] = robot.home
            half = robot.max_width / len(robot.finger_joints)
            d.qpos[idx.finger_qpos] = half
            d.ctrl[idx.finger_act] = half
        if self.scene.humanoid is not None:  # at home, fingers open; a floating base where the scene stands it
            from .humanoid_models import get_humanoid

            robot = get_humanoid(self.scene.humanoid.robot)
            idx = joint_indices(m, self.scene.humanoid.name, robot.JOINTS)
            d.qpos[idx.qpos] = d.ctrl[idx.act] = robot.home()
        mj.mj_forward(m, d)
        t = clock.now()
        self._t_origin = t - d.time          # wall time of sim time 0
        self._ctrl = LinearInterpolator(d.ctrl, t)  # each actuator towards its own timed target
        self._rtf_sim, self._rtf_wall, self._rtf = d.time, t, 1.0

    # -- loop -----------------------------------------------------------------------------------
    def _pick_up_commands(self, t_wall: float) -> None:
        stamp, target, t_target = self.bus.read_commands(self._seen)
        new = stamp != self._seen
        if not new.any():
            return
        self._seen = stamp
        self._ctrl.set_target(target, t_target, t_wall, where=new)

    def _pick_up_gains(self) -> None:
        stamp, kp, kd = self.bus.read_gains(self._gains_seen)
        new = np.flatnonzero(stamp != self._gains_seen)
        if len(new) == 0:
            return
        self._gains_seen = stamp
        m = self.model  # a position servo: force = kp (ctrl - q) - kd dq
        m.actuator_gainprm[new, 0] = kp[new]
        m.actuator_biasprm[new, 1] = -kp[new]
        m.actuator_biasprm[new, 2] = -kd[new]

    def read_state(self) -> dict[str, Any]:
        mj, m, d = self._mj, self.model, self.data
        now = clock.now()
        self._pick_up_commands(now)
        self._pick_up_gains()
        dt = m.opt.timestep
        n = int((now - (self._t_origin + d.time)) / dt)
        if n > self.max_steps:  # cannot keep up: drop the lag, simulated time slows down
            self._t_origin += (n - self.max_steps) * dt
            n = self.max_steps
        for _ in range(max(n, 0)):
            d.ctrl[:] = self._ctrl.sample(self._t_origin + d.time + dt)
            mj.mj_step(m, d)
        self.bus.write_state(d.time, d.qpos, d.qvel, d.ctrl, d.sensordata)
        if now - self._rtf_wall > 1.0:  # real-time factor over the last second or so
            self._rtf = (d.time - self._rtf_sim) / (now - self._rtf_wall)
            self._rtf_sim, self._rtf_wall = d.time, now
        poses = np.zeros((max(len(self.objects), 1), 7))
        for i, adr in enumerate(self._obj_qadr):
            poses[i] = d.qpos[adr:adr + 7]
        out = {"sim_time": float(d.time), "rtf": float(self._rtf), "object_poses": poses}
        if self.task is not None:
            t = float(d.time) - self._t_episode
            out.update(success=self.judge(d), task_time=t, time_up=t >= self.task.time_limit_s)
        return out

    # -- remote API -----------------------------------------------------------------------------
    @remote
    def reset(self) -> None:
        """Put objects, arms and a humanoid back where the scene starts them (they jump home); a task's
        clock restarts (its objects stay at the scene's places: `start_episode` draws a start)."""
        self._home()
        if self.task is not None:
            self._t_episode = float(self.data.time)
            self.bus.write_episode(self._t_episode, self.task.time_limit_s)
        self._seen = self.bus.cmd_stamp.copy()
        self.bus.write_state(self.data.time, self.data.qpos, self.data.qvel, self.data.ctrl, self.data.sensordata)

    @remote
    def set_object_pose(self, name: str, pose: list[float]) -> None:
        """Teleport a free object to `[x, y, z, qw, qx, qy, qz]` (world frame) at rest."""
        self._place(name, pose)
        self._mj.mj_forward(self.model, self.data)

    def _place(self, name: str, pose: Any) -> None:
        if name not in self.objects:
            raise KeyError(f"no free object '{name}'; objects: {self.objects}")
        m, d = self.model, self.data
        j = m.joint(name)
        d.qpos[j.qposadr[0]:j.qposadr[0] + 7] = np.asarray(pose, dtype=np.float64)
        d.qvel[j.dofadr[0]:j.dofadr[0] + 6] = 0.0

    @remote
    def start_episode(self, seed: int | None = None, episode: int = 0) -> dict[str, Any] | None:
        """Start episode `episode` of a run seeded `seed` (None: the task's own `seed`): the task's objects
        jump to that episode's drawn start and every other free object to where the scene puts it (an episode's
        start never depends on the episodes before it on the same world), at rest, and its clock restarts.
        Returns what to record of it (`rio_sim.task.EpisodeStart.to_json`, with the task's kind and time limit);
        None without a task (nothing moves). The arms stay where they are: a workflow starts each episode on a
        station just started, its arms at home, or sends them home first (`rio eval`). A free-floating humanoid
        (`mounted = false`) starts every episode standing at home, at rest, task or not: without it, what a
        locomotion policy starts from would be however far the body tipped while the station came up."""
        stood = self._stand_free_humanoid()
        if self.task is None:
            if stood:
                self.bus.write_state(self.data.time, self.data.qpos, self.data.qvel, self.data.ctrl,
                                     self.data.sensordata)
            return None
        start = self._start(self.task.seed if seed is None else int(seed), int(episode))
        self.bus.write_state(self.data.time, self.data.qpos, self.data.qvel, self.data.ctrl, self.data.sensordata)
        return {"kind": self.task.kind, "time_limit_s": self.task.time_limit_s, **start.to_json()}

    def _stand_free_humanoid(self) -> bool:
        """A free-floating humanoid back on its feet where the scene stands it: base pose and joints at home,
        nothing moving. False (nothing done) for a mounted one, or a scene without one."""
        h = self.scene.humanoid
        if h is None or h.mounted:
            return False
        from .humanoid_models import get_humanoid

        m, d, robot = self.model, self.data, get_humanoid(h.robot)
        base = m.joint(f"{h.name}/{robot.FREE_JOINT}")
        q, v = int(base.qposadr[0]), int(base.dofadr[0])
        d.qpos[q:q + 7], d.qvel[v:v + 6] = m.qpos0[q:q + 7], 0.0
        idx = joint_indices(m, h.name, robot.JOINTS)
        d.qpos[idx.qpos], d.qvel[idx.dof] = robot.home(), 0.0
        self._mj.mj_forward(m, d)
        return True

    def _start(self, seed: int, episode: int) -> Any:
        start = sample_start(self.task, self.scene, seed, episode)
        for name, adr in zip(self.objects, self._obj_qadr, strict=True):  # the others back where the scene has them
            if name not in start.poses:
                self._place(name, self.model.qpos0[adr:adr + 7])
        for name, pose in start.poses.items():
            self._place(name, pose)
        self._mj.mj_forward(self.model, self.data)
        self._t_episode = float(self.data.time)
        self.bus.write_episode(self._t_episode, self.task.time_limit_s)
        return start
