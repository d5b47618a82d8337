"""Env: the gym-style face of a station (`reset`, `step`, `get_state`), as in the RIO paper.

It owns the clients of its embodiment's roles, of every camera and of every sensor, connects them on
`__enter__` and closes them on `__exit__`. Every call is non-blocking: state comes from local ring
buffers and `step` only enqueues commands, so the control loop keeps its own timing.

A camera's pixels stay in its node's ring buffer until something reads them (`rio.schema.RingCamera`:
a recorder does at once; a policy node on this machine never needs the loop's copy). A camera frame
also says where it lives (`Camera.meta["source"]`: its camera node's ring, where the
middleware lets another process of this machine read it in place), so a policy node can take it from
there instead of receiving a copy in each request (`rio.policy.frames`).

Sensors (`<name>_sensor` roles: a force-torque sensor, the sim world's ground truth) belong to no
morphology, so they are not in the `Observation`: each step carries their latest numeric values in
`meta["sensors"][name]`, which the recorder stores as `meta.sensors.<name>.<key>` columns. The object poses
of the sensors that name their objects (a sim world) are the station's *environment state*
(`environment_names`, `environment_state`): what exports write as `observation.environment_state`, and what
`rio deploy` / `rio eval` hand a policy as `Observation.environment_state`.

A sensor may run a task (a sim world with a `[task]`): it offers `start_episode(seed, episode)`, which
`reset()` calls to put the world at that episode's start (a seeded draw) and which returns what to record
of it, and its samples carry `success`, `task_time` and `time_up`. The env keeps what it saw of them over
the episode (`task_over()` for the control loop, `task_result()` for the summary and the episode's metadata,
`task_success_held()` for `rio eval`, which ends a trial once success has held).
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from rio import clock
from rio.embodiments.base import Embodiment, EmbodimentConfig
from rio.errors import RioError
from rio.schema import Camera, Step

#: The elements of an object pose (position in m, then the unit quaternion w, x, y, z).
POSE_NAMES = ("x", "y", "z", "qw", "qx", "qy", "qz")


def environment_names(sensors: Mapping[str, Any]) -> dict[str, list[str]]:
    """{sensor name: element names} of the environment state: every sensor client that names its objects
    (`object_names()`, the rows of its `object_poses`), in the sensors' order, each object's pose as
    `<object>.x`, ..., `<object>.qz`."""
    return {name: [f"{o}.{c}" for o in client.object_names() for c in POSE_NAMES]
            for name, client in sensors.items() if "object_names" in dir(client)}


class Env:
    def __init__(self, embodiment: type[Embodiment], config: EmbodimentConfig,
                 robot_clients: Mapping[str, Callable[[], Any]], camera_clients: Mapping[str, Callable[[], Any]],
                 sensor_clients: Mapping[str, Callable[[], Any]] | None = None, *, rate_hz: float = 30.0,
                 station: str = "rio", drivers: Mapping[str, str] | None = None,
                 wrench_sources: Mapping[str, str] | None = None):
        self.embodiment_cls, self.config = embodiment, config
        #: {arm role: sensor name} of arms whose force limit reads a separate wrench node (`wrench_source`):
        #: each is handed a reference to its sensor once connected (`ArmNode.use_wrench_source`)
        self.wrench_sources: dict[str, str] = dict(wrench_sources or {})
        #: {role: driver name} of the station (`so101.follower`): the recorder's `robot_type`
        self.drivers: dict[str, str] = dict(drivers or {})
        self.robot_clients, self.camera_clients = robot_clients, camera_clients
        self.sensor_clients = dict(sensor_clients or {})
        self.rate_hz, self.station = float(rate_hz), station
        self.robot: Embodiment | None = None
        self.cameras: dict[str, Any] = {}
        self.sensors: dict[str, Any] = {}
        self.instruction: str | None = None
        self.timestep = 0
        #: The episode `reset()` starts on a task sensor: its number and the run's seed (None: the task's own).
        self.episode: int = 0
        self.seed: int | None = None
        self._task: dict[str, dict[str, Any]] = {}
        self._env_names: dict[str, list[str]] | None = None
        self.t_start: float | None = None
        self._stack: contextlib.ExitStack | None = None

    # -- lifecycle ----------------------------------------------------------------------------------
    def __enter__(self) -> Env:
        stack = contextlib.ExitStack()
        try:
            clients = {role: stack.enter_context(make()) for role, make in self.robot_clients.items()}
            self.cameras = {name: stack.enter_context(make()) for name, make in self.camera_clients.items()}
            self.sensors = {name: stack.enter_context(make()) for name, make in self.sensor_clients.items()}
            for arm, sensor in self.wrench_sources.items():  # every node is up: the arm connects its own client
                clients[arm].use_wrench_source(self.sensors[sensor].reference)
            self.robot = self.embodiment_cls(clients, self.config)
        except BaseException:
            stack.close()
            raise
        self._stack = stack
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._stack is not None:
            self._stack.close()
        self._stack, self.robot, self.cameras, self.sensors = None, None, {}, {}
        self._env_names = None

    def _robot(self) -> Embodiment:
        if self.robot is None:
            raise RioError(f"station '{self.station}': the env is not connected; use it as `with env:`")
        return self.robot

    # -- gym-style API ------------------------------------------------------------------------------
    @property
    def action_dim(self) -> int:
        return self._robot().action_dim

    def set_start_time(self, t_start: float) -> None:
        self.t_start = float(t_start)

    def reset(self, seed: int | None = None, episode: int | None = None) -> Step:
        """Start an episode: every task sensor starts episode `episode` (default `self.episode`) of a run
        seeded `seed` (default `self.seed`; None: the task's own seed), then the embodiment resets. Returns
        the state after both, with the task sensors' samples taken after their start."""
        robot = self._robot()
        seed = self.seed if seed is None else seed
        episode = self.episode if episode is None else int(episode)
        self._task = {}
        for name, client in self.sensors.items():
            if "start_episode" not in dir(client):
                continue
            info = client.start_episode(seed, episode)
            if info is not None:
                self._task[name] = {"info": dict(info), "first_success_s": None, "since": None, "last": {}}
                _wait_newer(client, clock.now())
        robot.reset()
        self.timestep = 0
        return self.get_state()

    # -- the environment state ----------------------------------------------------------------------
    def environment_state(self, step: Step) -> np.ndarray | None:
        """`step`'s environment state: its sensors' object poses (`environment_names`, read with the step),
        flattened into one float64 vector in that order, the vector exports write as
        `observation.environment_state`; None on a station without one."""
        names = self._environment_names()
        if not names:
            return None
        sensors = (step.meta or {}).get("sensors") or {}
        missing = [n for n in names if n not in sensors or "object_poses" not in sensors[n]]
        if missing:
            raise RioError(f"station '{self.station}': step {step.timestep} has no object poses of sensor(s) "
                           f"{missing}")
        return np.concatenate([np.asarray(sensors[n]["object_poses"], dtype=np.float64).reshape(-1) for n in names])

    def _environment_names(self) -> dict[str, list[str]]:
        if self._env_names is None:  # asked once per connection: a remote call per sensor
            self._env_names = environment_names(self.sensors)
        return self._env_names

    # -- the task's episode -------------------------------------------------------------------------
    def task_over(self) -> str | None:
        """Why the episode must end by the task's word (its time limit passed), from the samples the steps
        read; None while it goes on or without a task."""
        for t in self._task.values():
            if bool(t["last"].get("time_up", False)):
                return f"the task's time limit ({t['info'].get('time_limit_s', 0):g} s) passed"
        return None

    def task_result(self) -> dict[str, Any] | None:
        """The episode's task, judged now (each task sensor read once more): `success` (every task
        succeeded), `time_s` (the episode's task time), `first_success_s` (the task time success was first
        seen at a step, None if never), with what the sensor said of the episode's start (seed, episode,
        episode_seed, start poses, time limit). None without a task."""
        if not self._task:
            return None
        for name in self._task:
            self._note_task(name, self.sensors[name].get_state())
        out: dict[str, Any] = {}
        if len(self._task) == 1:
            out.update(next(iter(self._task.values()))["info"])
        else:
            out["sensors"] = {n: t["info"] for n, t in self._task.items()}
        times = [float(t["last"].get("task_time", 0.0)) for t in self._task.values()]
        firsts = [t["first_success_s"] for t in self._task.values()]
        out.update(success=all(bool(t["last"].get("success", False)) for t in self._task.values()),
                   time_s=round(max(times), 3),
                   first_success_s=None if None in firsts else round(max(firsts), 3))
        return out

    def task_success_held(self) -> tuple[float, float] | None:
        """(task time success began, seconds it has held since) when every task succeeds at the latest step
        read, without a break since it began; None otherwise or without a task."""
        if not self._task or any(t["since"] is None for t in self._task.values()):
            return None
        since = max(t["since"] for t in self._task.values())
        now = max(float(t["last"].get("task_time", 0.0)) for t in self._task.values())
        return since, now - since

    def _note_task(self, name: str, sample: dict[str, Any]) -> None:
        t = self._task[name]
        t["last"] = {k: sample[k] for k in ("success", "task_time", "time_up") if k in sample}
        succeeded = bool(sample.get("success", False))
        if t["first_success_s"] is None and succeeded:
            t["first_success_s"] = float(sample.get("task_time", 0.0))
        if not succeeded:
            t["since"] = None
        elif t["since"] is None:
            t["since"] = float(sample.get("task_time", 0.0))

    def step(self, action: Any, t_cmd_target: float | None = None) -> Step:
        """Send `action` (flat vector, see `robot.describe_action()`) to be reached at `t_cmd_target`
        (default: one control period from now); returns the latest state, tagged with the action."""
        robot = self._robot()
        parts = robot.split_action(action)
        t = clock.now() + 1.0 / self.rate_hz if t_cmd_target is None else float(t_cmd_target)
        robot.apply(parts, t)
        self.timestep += 1
        return self._make_step(np.concatenate(list(parts.values())), t_cmd_target=t)

    def get_state(self) -> Step:
        return self._make_step(None)

    # -- internals ----------------------------------------------------------------------------------
    def _make_step(self, action: np.ndarray | None, **meta: Any) -> Step:
        robot = self._robot()
        t_obs = clock.now()
        obs = robot.observe()
        obs.cameras = {name: self._camera(name, client) for name, client in self.cameras.items()}
        stamps = dict(robot.timestamps)
        stamps.update({f"{n}_camera": c.meta["timestamp"] for n, c in obs.cameras.items()})
        if self.sensors:
            meta["sensors"] = {name: self._sensor(name, client, stamps) for name, client in self.sensors.items()}
            for name in self._task:
                self._note_task(name, meta["sensors"][name])
        meta.update(t_obs=t_obs, timestamps=stamps, station=self.station)
        if self.t_start is not None:
            meta["t_start"] = self.t_start
        return Step(self.timestep, obs, self.instruction, action, meta)

    @staticmethod
    def _sensor(name: str, client: Any, stamps: dict[str, float]) -> dict[str, Any]:
        s = client.get_state()
        stamps[f"{name}_sensor"] = float(s["timestamp"])
        return {k: v for k, v in s.items() if k != "timestamp"}

    @staticmethod
    def _camera(name: str, client: Any) -> Camera:
        frame = getattr(client, "newest_frame", None)  # every CameraNode: pixels copied only when read
        cam = frame() if frame is not None else Camera.from_sample(client.get_state())
        source = getattr(client, "ring_ref", None)
        if source is not None:  # a policy node on this machine reads the frame from there (rio.policy.frames)
            cam.meta["source"] = source
        return cam


def _wait_newer(client: Any, t: float, timeout_s: float = 1.0) -> None:
    """Wait (at most `timeout_s`) for `client` to publish a sample stamped after `t`: the first state
    after a remote call is then the call's doing."""
    deadline = t + timeout_s
    while float(client.get_state()["timestamp"]) <= t and clock.now() < deadline:
        clock.precise_wait(clock.now() + 0.002)
