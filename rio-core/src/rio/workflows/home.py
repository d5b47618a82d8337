"""Homing: move every joint device of a station (arms, hands, a humanoid) to its home pose at a bounded speed.

An arm that rests folded on its joint limits and then starts end-effector teleop starts from there: IK tracks
a pose the arm cannot follow, the first run tracked with 1.99 rad of joint error and the tool went up 11 cm
instead of following its script. `rio home STATION` (and `--home` on teleop, deploy and replay) moves each
device first, through its own commander (`JointNode.move_to`: limits, the step limit, a single deliberate
move the stream watchdog never cuts), in a straight line in joint space whose fastest joint moves at `speed`
rad/s, then waits for it to arrive. The same moves the arms between the episodes of a recording session.

On real hardware the command line asks before anything moves (`--yes` skips it); on a stand-in station
(`is_stand_in`: sim, fake or emulator drivers) it does not.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rio import clock
from rio.errors import RioError

#: Default speed of the fastest joint while homing (rad/s): about 17 deg/s, slow enough to stop by hand.
HOME_SPEED = 0.3
#: How close (rad, every joint) a device must come to its home pose to count as there.
HOME_TOL = 0.02
#: Extra seconds a move may take past its planned time before homing gives up waiting (the step limit, a load).
HOME_SLACK_S = 5.0


@dataclass
class HomeResult:
    """What homing did, per device role: its planned time and its largest joint error at the end (rad)."""

    target: str = "home"
    seconds: dict[str, float] = field(default_factory=dict)
    error_rad: dict[str, float] = field(default_factory=dict)
    #: roles that have no such pose (a device without a declared rest pose)
    skipped: list[str] = field(default_factory=list)

    @property
    def arrived(self) -> bool:
        return all(e <= HOME_TOL for e in self.error_rad.values())

    def lines(self) -> list[str]:
        out = [f"{role}: at its {self.target} pose (largest joint error {self.error_rad[role]:.3f} rad, "
               f"{self.seconds[role]:.1f} s)" if self.error_rad[role] <= HOME_TOL else
               f"WARNING: {role} stopped {self.error_rad[role]:.3f} rad from its {self.target} pose" for role in
               self.error_rad]
        out += [f"{role}: declares no {self.target} pose; left where it is" for role in self.skipped]
        return out


def joint_devices(clients: dict[str, Any]) -> dict[str, Any]:
    """The connected clients that are joint devices (they have a home pose): arms, hands, a humanoid."""
    return {role: c for role, c in clients.items() if "home_pose" in dir(c) and "move_to" in dir(c)}


def is_stand_in(station: Any) -> bool:
    """True for a station whose robot is simulated, faked or emulated (no confirmation before homing): a
    component runs a simulator's world or an emulator, or every joint device's driver is a `sim.` or fake one."""
    drivers = [c.driver for c in station.components.values()]
    if any(d == "sim.world" or "emulator" in d for d in drivers):
        return True
    robot = [c.driver for role, c in station.components.items() if role in ("arm", "arm2", "humanoid", "hand",
                                                                             "hand2")]
    return bool(robot) and all(d.startswith(("sim.", "rio.fake")) for d in robot)


def _measured(client: Any) -> np.ndarray:
    return np.asarray(client.get_state()["joint_pos"], dtype=np.float64)


def home_devices(clients: dict[str, Any], *, speed: float = HOME_SPEED, rest: bool = False,
                 log: Callable[[str], None] | None = None, slack_s: float = HOME_SLACK_S) -> HomeResult:
    """Move every joint device among `clients` (role -> connected client) to its home pose (`rest`: its rest
    pose) at `speed` rad/s for its fastest joint, all at once, and wait until each is there (or its planned
    time plus `slack_s` has passed). Returns what happened; raises `RioError` naming a device that refuses."""
    if not speed > 0:
        raise RioError(f"the homing speed must be > 0 rad/s (got {speed})")
    say = log or (lambda _m: None)
    result = HomeResult("rest" if rest else "home")
    goals: dict[str, np.ndarray] = {}
    for role, c in joint_devices(clients).items():
        pose = c.rest_pose() if rest else c.home_pose()
        if pose is None:
            result.skipped.append(role)
            continue
        goal, q = np.asarray(pose, dtype=np.float64), _measured(c)
        seconds = float(np.max(np.abs(goal - q), initial=0.0)) / speed
        try:
            c.move_to(goal.tolist(), seconds)
        except Exception as e:  # a disabled or faulted device: said by name, the others are stopped
            for other in goals:
                joint_devices(clients)[other].hold()
            raise RioError(f"cannot move {role} to its {result.target} pose: {e}") from None
        goals[role], result.seconds[role] = goal, seconds
        say(f"{role}: moving to its {result.target} pose ({np.max(np.abs(goal - q), initial=0.0):.2f} rad away, "
            f"{seconds:.1f} s at {speed:g} rad/s)")
    devices = joint_devices(clients)
    t_end = clock.now() + max(result.seconds.values(), default=0.0) + slack_s
    while goals and clock.now() < t_end:
        errors = {r: float(np.max(np.abs(_measured(devices[r]) - g), initial=0.0)) for r, g in goals.items()}
        if all(e <= HOME_TOL for e in errors.values()):
            break
        clock.precise_wait(clock.now() + 0.05)
    for role, goal in goals.items():
        result.error_rad[role] = float(np.max(np.abs(_measured(devices[role]) - goal), initial=0.0))
    return result


def far_from_home(clients: dict[str, Any], tol: float = 0.5) -> dict[str, float]:
    """Joint devices more than `tol` rad (any joint) from their home pose: {role: largest error}."""
    out = {}
    for role, c in joint_devices(clients).items():
        err = float(np.max(np.abs(_measured(c) - np.asarray(c.home_pose(), dtype=np.float64)), initial=0.0))
        if err > tol:
            out[role] = err
    return out


def run_home(station: Any, *, speed: float = HOME_SPEED, rest: bool = False, middleware: str | None = None,
             log: Callable[[str], None] | None = print, ready_timeout: float | None = None,
             registry: Any = None) -> HomeResult:
    """`rio home STATION`: start the station, move its joint devices home (or to rest), stop it."""
    from rio.workflows.run import open_session

    with open_session(station, middleware=middleware, log=log, ready_timeout=ready_timeout,
                      registry=registry) as session:
        return home_devices(session.env.robot.clients, speed=speed, rest=rest, log=log)
