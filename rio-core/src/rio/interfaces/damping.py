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

A driver mixes `DampingSafety` in ahead of its kind (`class G1(DampingSafety, HumanoidNode)`) and
`DampingConfig` (or `BodyDampingConfig`, which adds the fall limit) into its `Config`, sets `t_state`
(`rio.clock.now()`) whenever a state arrives, calls `watch_safety()` in `read_joints()` once it has read
the state, and calls `check_device_fault()` in `set_enabled(True)`. What is the vendor's stays in its hooks:

- `state_lost(age)`: its named fault for the silence (`state_lost(...)` below, with its topic and address);
- `tilt_deg()`: its base's tilt from its IMU (`tilt_from_quat` or `tilt_from_rpy`), None without one;
- `send_damping()`: its soft command, sent every cycle the node is disabled or faulted;
- its own mode changes (asking the robot for its damping mode) in `set_enabled(False)` / `on_fault()`.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import Field

from .. import clock
from ..config import Config
from ..control.rotations import quat_to_matrix
from .faults import Fault, FaultHolding

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


# -- the mixin ----------------------------------------------------------------------------------------------
class DampingSafety(FaultHolding):
    """Mixed in ahead of a joint kind: the three stops, and damping every cycle while disabled."""

    config: Any
    _commander: Any
    #: `rio.clock.now()` of the last state the device sent (the driver sets it).
    t_state: float = -math.inf
    #: When `watch_safety` last looked, and how long the state had been missing then (see `state_age`).
    _t_watched: float = -math.inf
    _missing_s: float = 0.0
    #: Where the IMU sits, as the fall fault names it.
    body: str = "body"
    #: What a cleared stale fault holds ("robot", "hand").
    device_noun: str = "robot"
    _holds_seen = 0

    # -- driver hooks -----------------------------------------------------------------------------------
    def state_lost(self, age: float) -> Fault:
        """The driver's named fault for `age` seconds without a state (built with `state_lost(...)`)."""
        raise NotImplementedError(f"{type(self).__name__} must define state_lost(age)")

    def tilt_deg(self) -> float | None:
        """The base's tilt from upright now (deg), or None: no IMU, or no state yet."""
        return None

    def send_damping(self) -> None:
        """Send the device's soft command (kp = 0); called every cycle the node is disabled or faulted."""
        raise NotImplementedError(f"{type(self).__name__} must define send_damping()")

    # -- shared -------------------------------------------------------------------------------------------
    @property
    def damps_on_stale(self) -> bool:
        """Whether a stream of commands that stops is damped (a fault) rather than held stiff."""
        return bool(self.config.on_stale == "damp")

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
        gap = max(self.config.state_timeout_s / 10, 3.0 / float(getattr(self, "rate_hz", 0.0) or math.inf))
        return self._missing_s + min(max(now - self._t_watched, 0.0), gap)

    def device_fault(self) -> Fault | None:
        """The conditions that hold now (a stale stream is not one: it ends when commands come again)."""
        age = self.state_age(clock.now())
        if age > self.config.state_timeout_s:
            return self.state_lost(age)
        tilt = self.tilt_deg()
        if tilt is not None and self.config.fall_tilt_deg is not None and tilt > self.config.fall_tilt_deg:
            return fall(tilt, self.config.fall_tilt_deg, self.body)
        return None

    def check_device_fault(self) -> None:
        """Before enabling: refused while a cause lasts; a stream that went stale before now is forgotten."""
        super().check_device_fault()
        if self._commander is not None:
            self._holds_seen = self._commander.watchdog_holds

    def watch_safety(self) -> None:
        """The driver's own stops, once per cycle after reading the state: the device's silence, a fall,
        a stream of commands that stopped (the kind's watchdog held it) while `on_stale = "damp"`."""
        now = clock.now()
        self._missing_s, self._t_watched = self.state_age(now), now
        if self.fault is not None and self.fault.code != STALE_COMMANDS:
            return
        fault = self.device_fault()
        holds = self._commander.watchdog_holds if self._commander is not None else self._holds_seen
        if fault is None and holds > self._holds_seen:
            self._holds_seen = holds
            if self.damps_on_stale and self.enabled:
                fault = stale_commands(self.config.watchdog_s, self.device_noun)
        if fault is not None:
            self.on_fault(fault)

    def read_state(self) -> dict[str, Any]:
        sample: dict[str, Any] = super().read_state()  # type: ignore[misc]  # the kind's
        if not self.enabled:
            self.send_damping()
        return sample
