"""Damping safety: the stops a low-level humanoid (or hand) driver makes by itself, leaving the device soft.

A humanoid on its low-level topics obeys whatever it last received and reports no faults a driver could
act on, so the driver stops it itself, each time with a named fault (`rio.interfaces.Fault`) held until
`clear_faults()`, which refuses while the cause lasts:

| code | name (the driver's)  | when                                                                |
|------|----------------------|---------------------------------------------------------------------|
| 1    | e.g. lowstate_timeout | no state for `state_timeout_s` while the driver runs (a cable, a reboot) |
| 2    | fall                 | the base tilted beyond `fall_tilt_deg` from upright (humanoids)      |
| 3    | stale_commands       | a stream of commands stopped (the kind's watchdog) with `on_stale = "damp"` |

Why damping and not the kind's usual hold: a stiff hold of the last pose of a body that is falling, or
that a crashed policy left mid-step, fights the fall and the people catching it; kp = 0 with some
damping lets it go down slowly. `on_stale = "hold"` keeps the kind's stiff hold for a stale stream.

A driver mixes `DampingConfig` (or `BodyDampingConfig`, which adds the fall limit) into its `Config` and
gives its node two parts in `setup()`, the guard and the fault holder the guard's faults are held by:

    self.safety = DampingGuard(self, self.state_lost, tilt=self.tilt_deg, body="pelvis")
    self.faults = FaultHolder(self, "the G1 on eth0", ask=self.safety.device_fault)

It sets `self.safety.t_state` (`rio.clock.now()`) whenever a state arrives and calls `self.safety.watch()`
in `read_joints()` once it has read the state; the kind refuses `enable()` while a cause lasts. What is the
vendor's stays in the driver:

- `state_lost(age)`: its named fault for the silence (`state_lost(...)` below, with its topic and address);
- `tilt`: its base's tilt from its IMU (`tilt_from_quat` or `tilt_from_rpy`), None without one;
- `write_disabled()` (the joint kind's hook): its soft command, sent every cycle the node is disabled or
  faulted;
- its own mode changes (asking the robot for its damping mode) in `set_enabled(False)` and
  `write_disabled()`.
"""


from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio import clock
from rio.config import Config
from rio.control.rotations import quat_to_matrix
from rio.interfaces.faults import Fault

#: `fault_code` of each stop (the same on every driver, so a script can match them across vendors).
STATE_LOST, FALL, STALE_COMMANDS = 1, 2, 3

OnStale = Literal["damp", "hold"]


# -- the faults ---------------------------------------------------------------------------------------------
def state_lost(name: str, topic: str, seconds: float, where: str, check: str) -> Fault:
    """No `topic` for `seconds` on `where` ("interface 'eth0' (DDS domain 0)"); `check`: what to look at
    first ("check the cable, ..."), before `clear_faults()`."""
    return Fault(STATE_LOST, name, f"no {topic} for {seconds:.2f} s on {where}",
                 f"{check}; clear_faults() once it publishes again")


def fall(tilt_deg: float, limit_deg: float, body: str) -> Fault:
    """`body` ("pelvis", "trunk": where the IMU sits) tilted `tilt_deg` from upright, beyond `limit_deg`."""
    return Fault(FALL, "fall", f"the {body} is tilted {tilt_deg:.0f} deg from upright (fall_tilt_deg "
                               f"{limit_deg:.0f}): damping",
                 "hang or stand the robot upright, then clear_faults()")


def stale_commands(watchdog_s: float, device: str = "robot") -> Fault:
    return Fault(STALE_COMMANDS, "stale_commands",
                 f"the stream of commands stopped for more than watchdog_s ({watchdog_s} s): damping",
                 f"clear_faults() or enable() holds where the {device} is; then command again")


# -- tilt from an IMU ---------------------------------------------------------------------------------------
def tilt_from_quat(quat_wxyz: Any) -> float:
    """Angle (deg) between the body's up axis and the world's, from the IMU's orientation [w, x, y, z]
    (any norm): yaw never counts. NaN for a quaternion an IMU could not have meant (zero, NaN)."""
    q = np.asarray(quat_wxyz, dtype=np.float64)
    n = float(q @ q)
    if not math.isfinite(n) or n < 1e-9:
        return math.nan
    up_z = float(quat_to_matrix(q)[2, 2])  # z of the body's z axis in the world frame
    return math.degrees(math.acos(max(-1.0, min(1.0, up_z))))


def tilt_from_rpy(rpy: Any) -> float:
    """The same from roll, pitch, yaw (rad; fixed-axis x-y-z, `rio.control.rotations.euler_to_quat`'s),
    as IMUs that report Euler angles give them: the body's up axis has world z = cos(roll) cos(pitch)."""
    r, p = float(rpy[0]), float(rpy[1])
    if not (math.isfinite(r) and math.isfinite(p)):
        return math.nan
    return math.degrees(math.acos(max(-1.0, min(1.0, math.cos(r) * math.cos(p)))))


# -- config -------------------------------------------------------------------------------------------------
class DampingConfig(Config):
    """Station fields of a driver with damping safety (mixed into its Config)."""

    state_timeout_s: float = Field(0.25, gt=0, description="fault (damping) when no state arrives from the "
                                                           "device for this long (s)")
    on_stale: OnStale = Field("damp", description='when a stream of commands stops (watchdog_s): "damp" (fault, '
                                                  'kp = 0) or "hold" (keep the last goal stiff)')
    connect_timeout_s: float = Field(5.0, gt=0, description="how long open() waits for the first state from the "
                                                            "device (s)")


class MotorGainsConfig(Config):
    """Per-joint gains of a device whose motors close the position loop themselves (a humanoid's or hand's
    low-level command carries q, kp, kd per motor): None takes the driver's table (its README)."""

    kp: list[float] | None = Field(None, description="stiffness per joint (N·m/rad), in the node's joint order")
    kd: list[float] | None = Field(None, description="damping per joint while holding a goal (N·m·s/rad)")
    damping_kd: list[float] | None = Field(None, description="kd per joint of the damping command (kp = 0)")


def motor_gains(config: Any, defaults: dict[str, list[float]], node: str, dof: int) -> dict[str, list[float]]:
    """kp, kd and damping_kd per joint (`MotorGainsConfig`): the config's where given, one value per joint
    (a clear error naming the field otherwise), else `defaults` (same keys)."""
    gains = {}
    for name in ("kp", "kd", "damping_kd"):
        value = getattr(config, name)
        if value is not None and len(value) != dof:
            raise ValueError(f"{name} has {len(value)} values; node '{node}' drives {dof} joints")
        gains[name] = [float(v) for v in (value if value is not None else defaults[name])]
    return gains


class BodyDampingConfig(DampingConfig):
    """A humanoid's: damping safety plus the fall limit."""

    fall_tilt_deg: float | None = Field(45.0, gt=0, le=180, description="fault (damping) when the base tilts "
                                                                        "beyond this from upright; None: off")


# -- the part -----------------------------------------------------------------------------------------------
class DampingGuard:
    """The three stops of a device on low-level topics (the module docstring), a part its driver gives the
    node. `state_lost(age)`: the driver's named fault for `age` seconds without a state; `tilt()`: the
    base's tilt from upright now (deg), None without an IMU or before the first state; `body`: where the
    IMU sits, as the fall fault names it; `device_noun`: what a cleared stale fault holds."""

    def __init__(self, node: Any, state_lost: Callable[[float], Fault], *,
                 tilt: Callable[[], float | None] = lambda: None, body: str = "body", device_noun: str = "robot"):
        self.node, self.state_lost, self.tilt = node, state_lost, tilt
        self.body, self.device_noun = body, device_noun
        #: `rio.clock.now()` of the last state the device sent (the driver sets it).
        self.t_state = -math.inf
        #: When `watch` last looked, and how long the state had been missing then (see `state_age`).
        self._t_watched, self._missing_s = -math.inf, 0.0
        self._holds_seen = 0

    @property
    def damps_on_stale(self) -> bool:
        """Whether a stream of commands that stops is damped (a fault) rather than held stiff."""
        return bool(self.node.config.on_stale == "damp")

    def state_age(self, now: float) -> float:
        """How long the device's state has been missing at `now`, counted while this driver ran to look:
        of the time between two of its looks, at most a tenth of `state_timeout_s` (or three cycles, if
        longer). A process that was stalled itself (descheduled on a loaded host, its GIL held by another
        thread) could not have taken a state in meanwhile, however well the device published: on a loaded
        2-core machine the emulated T1's stream and its driver, one process, stopped together for up to
        0.35 s, and the driver damped the robot for its own stall (lowstate_timeout). A device that went
        quiet is still faulted after `state_timeout_s` while the driver runs at its rate (later, when the
        driver itself only runs now and then)."""
        if self.t_state > self._t_watched or self._t_watched == -math.inf:  # a state since the last look
            return max(now - self.t_state, 0.0)
        c = self.node.config
        gap = max(c.state_timeout_s / 10, 3.0 / float(getattr(self.node, "rate_hz", 0.0) or math.inf))
        return self._missing_s + min(max(now - self._t_watched, 0.0), gap)

    def device_fault(self) -> Fault | None:
        """The conditions that hold now (a stale stream is not one: it ends when commands come again); the
        fault holder's `ask`."""
        c = self.node.config
        age = self.state_age(clock.now())
        if age > c.state_timeout_s:
            return self.state_lost(age)
        tilt = self.tilt()
        if tilt is not None and c.fall_tilt_deg is not None and tilt > c.fall_tilt_deg:
            return fall(tilt, c.fall_tilt_deg, self.body)
        return None

    def watch(self) -> None:
        """The driver's own stops, once per cycle after reading the state: the device's silence, a fall, a
        stream of commands that stopped (the kind's watchdog held it) while `on_stale = "damp"`. A watchdog
        hold counts once, in the cycle after it: one from before a fault is not a reason to stop again."""
        now = clock.now()
        self._missing_s, self._t_watched = self.state_age(now), now
        node, faults = self.node, self.node.faults
        commander = node._commander
        holds = commander.watchdog_holds if commander is not None else self._holds_seen
        new_hold, self._holds_seen = holds > self._holds_seen, holds
        if faults.fault is not None and faults.fault.code != STALE_COMMANDS:
            return
        fault = self.device_fault()
        if fault is None and new_hold and self.damps_on_stale and node.enabled:
            fault = stale_commands(node.config.watchdog_s, self.device_noun)
        if fault is not None:
            faults.report(fault)
