"""A station's teleop device(s) giving actions in the robot's feature names: what `RioTeleoperator` runs.

Nothing here imports LeRobot. The device nodes (the station's `teleop` / `teleop2` roles, or the one
`device` names: keyboard, scripted, a SpaceMouse driver, a leader arm) are served here; the controller
is RIO's own, unchanged: `rio.teleop.twist.TwistTeleop` for a twist device (end-effector targets
integrated from the twist, IK for joint-space arms) or `rio.teleop.leader_follower.LeaderFollower` for a
leader arm, exactly as `rio teleop` builds them (`rio.workflows.teleop.run_teleop`). LeRobot's loop stands
in for `rio.loop.control_loop.ControlLoop`: each `action()` is one tick of that controller.

The controller reads the arms of the `RioRobot` of the same station connected in this process (LeRobot
gives a teleoperator no access to its robot; `lerobot-teleoperate` even connects the teleoperator
first), so it binds to them at its first action.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from typing import Any

import numpy as np

from rio import clock
from rio.errors import RioError
from rio.station.build import make_station

from .bridge import ACTIVE, DEVICE_ROLES, BridgeError, about, action_parts, log, offline_embodiment


@dataclass
class _LoopView:
    """What a RIO teleop controller reads from its `ControlLoop` in `reset()`."""

    env: Any
    rate_hz: float
    say: Any
    duration: float | None = None

    @property
    def dt(self) -> float:
        return 1.0 / self.rate_hz


class DeviceBridge:
    """The teleop device(s) of `station` (or `device` instead), served and read here; `action()` gives the
    station's flat action as a dict of its feature names."""

    def __init__(self, station: str, *, device: str | None = None, middleware: str | None = None,
                 mode: str = "translation", max_pos_speed: float = 0.15, max_rot_speed: float = 1.0,
                 align_speed: float = 0.5, filter_hz: float | None = 8.0):
        from rio.control.teleop import TeleopMode
        from rio.workflows.teleop import drives_leader_arm, prepare_station

        if not station:
            raise BridgeError("no station given: set --teleop.station=<the robot's station, name or .toml path>")
        try:
            TeleopMode.parse(mode)
            self.station = prepare_station(station, device)
            servers, self.clients, env = make_station(self.station, middleware=middleware)
        except (RioError, ValueError) as e:
            raise BridgeError(about(station, e)) from None
        self.name = self.station.name
        self.roles = [r for r in DEVICE_ROLES if r in self.station.components]
        if not self.roles:
            raise BridgeError(f"rio station '{self.name}' has no teleop component: name a device with "
                              "--teleop.device=keyboard, scripted or a registered teleop driver")
        if env is None:
            raise BridgeError(f"rio station '{self.name}' has no arm or humanoid to drive (roles: "
                              f"{sorted(self.station.roles())})")
        self.driver = self.station.components["teleop"].driver if "teleop" in self.roles else self.roles[0]
        self.servers = {r: servers[r] for r in self.roles if r in servers}
        self.names = [n for p in action_parts(offline_embodiment(self.name, env)) for n in p.names]
        self.leader = drives_leader_arm(self.station)
        self.options = dict(mode=mode, max_pos_speed=max_pos_speed, max_rot_speed=max_rot_speed,
                            align_speed=align_speed, filter_hz=filter_hz)
        self._stack: contextlib.ExitStack | None = None
        self.controller: Any = None
        self.robot: Any = None

    @property
    def running(self) -> bool:
        return self._stack is not None

    def start(self) -> None:
        """Serve the device node(s) of this station (in its namespace, beside the robot's nodes)."""
        from rio.runtime.manager import ServerManager

        if self.running:
            return
        stack = contextlib.ExitStack()
        try:
            if self.servers:
                stack.enter_context(ServerManager(self.servers, station=self.name))
        except BaseException:
            stack.close()
            raise
        self._stack = stack

    def stop(self) -> None:
        stack, self._stack = self._stack, None
        self.controller = self.robot = None
        if stack is not None:
            stack.close()

    def _bind(self) -> None:
        """Build RIO's teleop controller on the connected robot of this station, as `rio teleop` does."""
        from rio.teleop.leader_follower import LeaderFollower
        from rio.teleop.twist import TwistTeleop
        from rio.workflows.run import Session

        robot = ACTIVE.get(self.name)
        if robot is None or not robot.running:
            raise BridgeError(f"rio teleop: no connected rio robot of station '{self.name}' in this process; the "
                              f"rio teleoperator drives --robot.type=rio --robot.station={self.name} (connect it "
                              "before asking for actions)")
        if robot.names != self.names:
            raise BridgeError(f"rio teleop: station '{self.name}': the robot's action {robot.names} differs from "
                              f"the teleoperator's {self.names}")
        assert self._stack is not None
        o = self.options
        if self.leader:
            session = Session(robot.env, self.clients, self._stack, self.station, log.info)
            controller: Any = LeaderFollower.connect(session, align_speed=o["align_speed"])
        else:
            devices = {r: self._stack.enter_context(self.clients[r]()) for r in self.roles}
            controller = TwistTeleop(devices, device=self.driver, mode=o["mode"], max_pos_speed=o["max_pos_speed"],
                                     max_rot_speed=o["max_rot_speed"], filter_hz=o["filter_hz"])
        controller.reset(_LoopView(robot.env, robot.rate_hz, log.info))
        self.controller, self.robot = controller, robot
        self.t0, self.it = clock.now(), 0

    def action(self) -> dict[str, float]:
        """One tick of the controller: the station's action as {feature name: value}."""
        from rio.loop.control_loop import Tick

        if not self.running:
            raise BridgeError(f"rio teleop of station '{self.name}' is not connected")
        if self.controller is None or not self.robot.running:
            self._bind()
        t = clock.now()
        dt = 1.0 / self.robot.rate_hz
        flat = self.controller.step(Tick(t, t + dt, self.t0, self.it, True, None, self.robot.env))
        self.it += 1
        if flat is None:  # hold: the arms' current targets
            flat = self.robot.env.get_state().observation.proprio
        return self.robot.as_dict(np.asarray(flat, dtype=np.float64))

    @property
    def finished(self) -> bool:
        """The device pressed its done button (or its script ended)."""
        return bool(self.controller is not None and self.controller.done())
