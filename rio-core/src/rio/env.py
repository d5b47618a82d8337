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
`meta["sensors"][name]`, which the recorder stores as `meta.sensors.<name>.<key>` columns.
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


class Env:
    def __init__(self, embodiment: type[Embodiment], config: EmbodimentConfig,
                 robot_clients: Mapping[str, Callable[[], Any]], camera_clients: Mapping[str, Callable[[], Any]],
                 sensor_clients: Mapping[str, Callable[[], Any]] | None = None, *, rate_hz: float = 30.0,
                 station: str = "rio"):
        self.embodiment_cls, self.config = embodiment, config
        self.robot_clients, self.camera_clients = robot_clients, camera_clients
        self.sensor_clients = dict(sensor_clients or {})
        self.rate_hz, self.station = float(rate_hz), station
        self.robot: Embodiment | None = None
        self.cameras: dict[str, Any] = {}
        self.sensors: dict[str, Any] = {}
        self.instruction: str | None = None
        self.timestep = 0
        self.t_start: float | None = None
        self._stack: contextlib.ExitStack | None = None

    # -- lifecycle ----------------------------------------------------------------------------------
    def __enter__(self) -> Env:
        stack = contextlib.ExitStack()
        try:
            clients = {role: stack.enter_context(make()) for role, make in self.robot_clients.items()}
            self.cameras = {name: stack.enter_context(make()) for name, make in self.camera_clients.items()}
            self.sensors = {name: stack.enter_context(make()) for name, make in self.sensor_clients.items()}
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

    def reset(self) -> Step:
        self._robot().reset()
        self.timestep = 0
        return self.get_state()

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
