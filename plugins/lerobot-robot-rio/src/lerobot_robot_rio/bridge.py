"""A RIO station seen as flat, named features: what `RioRobot` and `RioTeleoperator` are built on.

Nothing here imports LeRobot, so it is tested and usable without it.

Features are known before anything starts (LeRobot asks for them before `connect()`): the station
file is validated with `rio.station.build.make_station` (which starts nothing), each node's object is
built here from its validated config (its `setup()`: no hardware, no processes), and the embodiment
is assembled over those local objects to read its action layout, the arms' joint names and the
cameras' frame sizes.

Naming (one name per value of RIO's flat action, in its order; the observation's state uses the
same names for RIO's `proprio`, which is in action space, same order and units):

- arm in joint space: `<joint>.pos` (rad), joint names from the arm driver (`joint_names()`);
- arm in end-effector space (`[embodiment] action_space = "eef_pose"`): `eef.x`, `eef.y`, `eef.z` (m,
  base frame), `eef.qw`, `eef.qx`, `eef.qy`, `eef.qz`;
- gripper: `gripper.pos` (opening, m);
- hand: `<hand joint>.pos` (rad);
- two arms (`arm` + `arm2`): every name of the first group prefixed `arm1_`, of the second `arm2_`
  (RIO's own action labels), so identical arms never collide;
- anything else (a plugin's embodiment): `<label>.<i>`.

Cameras: `<name>` (the role without `_camera`) -> (height, width, 3) uint8 RGB. Depth is not exported.
"""

from __future__ import annotations

import contextlib
import logging
import math
import signal
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from rio import clock
from rio.errors import RioError
from rio.station import roles as R
from rio.station.build import make_station
from rio.station.load import load_station

log = logging.getLogger("lerobot_robot_rio")

EEF_NAMES = ("x", "y", "z", "qw", "qx", "qy", "qz")
#: The teleop device roles: served and read by a RioTeleoperator.
DEVICE_ROLES = ("teleop", "teleop2")
#: Component kinds a RioRobot does not serve: teleop devices belong to the teleoperator, a station's policy
#: to RIO's own deploy (under LeRobot the policy is LeRobot's).
NOT_SERVED_KINDS = ("teleop", "policy")

#: Connected stations of this process, by station name: a RioTeleoperator drives the arms of the RioRobot of
#: its station through these (LeRobot gives a teleoperator no access to the robot).
ACTIVE: dict[str, StationBridge] = {}


class BridgeError(RioError, ValueError):
    """A problem with a station or an action, naming the station and the field."""


@dataclass(frozen=True)
class Part:
    """One part of RIO's flat action (`Embodiment.action_parts()`), with the feature names of its values."""

    label: str
    role: str | None
    names: tuple[str, ...]


def _role_of(label: str, roles: set[str]) -> tuple[str, str | None, str]:
    """(prefix, station role, kind) of an action label of the standard embodiments."""
    for kind in ("joint_pos", "eef_pose", "gripper", "hand"):
        if label.endswith(kind):
            prefix = label[: -len(kind)]
            break
    else:
        return "", None, "other"
    second = "2" if prefix == "arm2_" else ""
    if kind in ("joint_pos", "eef_pose"):
        role = "humanoid" if "humanoid" in roles and not prefix else f"arm{second}"
    elif kind == "hand" and "humanoid" in roles:
        role = label  # a humanoid's parts "hand" / "hand2" are its hand roles
    else:
        role = f"{kind}{second}"
    return prefix, (role if role in roles else None), kind


def _clean(name: str) -> str:
    return name.replace("/", "_")  # LeRobot refuses '/' in feature names


def action_parts(embodiment: Any) -> list[Part]:
    """The named parts of an embodiment's action (its clients: connected or local node objects)."""
    roles = set(embodiment.clients)
    parts = []
    for label, n in embodiment.action_parts():
        prefix, role, kind = _role_of(label, roles)
        names: list[str] | None = None
        if kind in ("joint_pos", "hand") and role is not None:
            joints = [str(j) for j in embodiment.clients[role].joint_names()]
            if len(joints) == n:
                names = [_clean(f"{prefix}{j}.pos") for j in joints]
        elif kind == "eef_pose" and n == len(EEF_NAMES):
            names = [f"{prefix}eef.{c}" for c in EEF_NAMES]
        elif kind == "gripper" and n == 1:
            names = [f"{prefix}gripper.pos"]
        if names is None:
            names = [_clean(f"{label}.{i}") for i in range(n)] if n > 1 else [_clean(label)]
        parts.append(Part(label, role, tuple(names)))
    seen: dict[str, int] = {}
    for p in parts:
        for name in p.names:
            seen[name] = seen.get(name, 0) + 1
    if any(c > 1 for c in seen.values()):  # e.g. a hand joint named like an arm joint: qualify by the label
        parts = [p if all(seen[x] == 1 for x in p.names) else
                 Part(p.label, p.role, tuple(_clean(f"{p.label}.{x}") for x in p.names)) for p in parts]
    return parts


class StationBridge:
    """A station's servers, `Env` and feature names; `start()` / `stop()` run it (what `RioRobot` does).

    `station`: a registered station name or a .toml path; `middleware`: overrides the file's;
    `rate_hz`: the control rate commands are timed for (default: the station's `rate_hz`)."""

    def __init__(self, station: str, *, middleware: str | None = None, rate_hz: float | None = None):
        if not station:
            raise BridgeError("no station given: set --robot.station=<registered name or station .toml path> "
                              "(`rio stations list` shows the registered ones)")
        try:
            self.station = load_station(station)
            servers, self.clients, env = make_station(self.station, middleware=middleware)
        except (RioError, ValueError) as e:  # ConfigError: an unknown station, a bad file, a missing plugin
            raise BridgeError(about(station, e)) from None
        if env is None:
            raise BridgeError(f"rio station '{self.station.name}' has no arm or humanoid to drive (roles: "
                              f"{sorted(self.station.roles())})")
        if rate_hz is not None and not rate_hz > 0:
            raise BridgeError(f"rio station '{self.station.name}': rate_hz must be > 0, got {rate_hz}")
        self.name = self.station.name
        self.env = env
        self.rate_hz = float(rate_hz or self.station.rate_hz)
        self.servers = {r: s for r, s in servers.items() if R.kind_of(r) not in NOT_SERVED_KINDS}
        self.parts = action_parts(offline_embodiment(self.name, env))
        self.names = [n for p in self.parts for n in p.names]
        self.cameras = camera_shapes(self.name, env)
        self.run_ids: list[str] = []
        self._stack: contextlib.ExitStack | None = None
        self._lower = np.full(len(self.names), -np.inf)
        self._upper = np.full(len(self.names), np.inf)
        self._warned_extra = False

    # -- lifecycle ----------------------------------------------------------------------------------
    @property
    def running(self) -> bool:
        return self._stack is not None

    def start(self) -> None:
        """Start the station's nodes (a `ServerManager`), then connect its `Env`: the order of every RIO
        workflow (`rio.workflows.run.run_workflow`)."""
        from rio.runtime.manager import ServerManager

        if self.running:
            return
        if self.name in ACTIVE:
            raise BridgeError(f"rio station '{self.name}' is already connected in this process")
        stack = contextlib.ExitStack()
        try:
            stack.enter_context(_SigtermAsExit())
            manager = stack.enter_context(ServerManager(self.servers, station=self.name))
            self.run_ids = [manager.run_id]
            stack.enter_context(self.env)
            self.env.rate_hz = self.rate_hz
            robot = self.env.robot
            live = action_parts(robot)
            if [p.names for p in live] != [p.names for p in self.parts]:
                raise BridgeError(f"rio station '{self.name}': the running station's action "
                                  f"{[n for p in live for n in p.names]} differs from the one announced before "
                                  f"connecting {self.names}")
            self._read_limits(robot)
            self.env.reset()
            self.env.set_start_time(clock.now())
        except BaseException:
            stack.close()
            raise
        self._stack = stack
        ACTIVE[self.name] = self

    def stop(self) -> None:
        """Disconnect the env, then stop the nodes (their shared memory goes with them)."""
        stack, self._stack = self._stack, None
        if ACTIVE.get(self.name) is self:
            del ACTIVE[self.name]
        if stack is not None:
            stack.close()

    def _read_limits(self, robot: Any) -> None:
        """The limits the nodes clip targets to (joint limits, gripper range), to report what is sent."""
        lower, upper = [], []
        for p in self.parts:
            n = len(p.names)
            lo, hi = np.full(n, -np.inf), np.full(n, np.inf)
            client = robot.clients.get(p.role) if p.role else None
            try:
                if client is not None and p.label.endswith(("joint_pos", "hand")):
                    lim = np.asarray(client.joint_limits(), dtype=np.float64)
                    if lim.shape == (2, n):
                        lo, hi = lim[0], lim[1]
                elif client is not None and p.label.endswith("gripper") and n == 1:
                    lo, hi = np.zeros(1), np.array([float(client.max_width())])
            except (AttributeError, RioError) as e:  # a driver without them: the node still clips
                log.debug("no limits for %s: %s", p.label, e)
            lower.append(lo)
            upper.append(hi)
        self._lower, self._upper = np.concatenate(lower), np.concatenate(upper)

    # -- observation / action -----------------------------------------------------------------------
    def observation(self) -> dict[str, Any]:
        """The env's newest state: `proprio` by name (floats), each camera's newest RGB frame (HxWx3 uint8)."""
        obs = self._env().get_state().observation
        proprio = np.asarray(obs.proprio, dtype=np.float64).reshape(-1)
        if proprio.size != len(self.names):
            raise BridgeError(f"rio station '{self.name}': proprio has {proprio.size} values, expected "
                              f"{len(self.names)} ({', '.join(self.names)})")
        out: dict[str, Any] = {n: float(v) for n, v in zip(self.names, proprio, strict=True)}
        for cam, shape in self.cameras.items():
            c = obs.cameras.get(cam)
            rgb = None if c is None else c.rgb
            if rgb is None:
                raise BridgeError(f"rio station '{self.name}': camera '{cam}' gave no RGB frame")
            rgb = np.asarray(rgb)
            if rgb.shape != shape or rgb.dtype != np.uint8:
                raise BridgeError(f"rio station '{self.name}': camera '{cam}' gave a {rgb.dtype} frame of shape "
                                  f"{rgb.shape}, expected uint8 {shape}")
            out[cam] = rgb
        return out

    def flat_action(self, action: Mapping[str, Any], who: str = "action") -> np.ndarray:
        """A LeRobot action dict -> RIO's flat action; a missing name or a non-finite value is a BridgeError."""
        if not isinstance(action, Mapping):
            raise BridgeError(f"rio station '{self.name}': {who} must be a dict of {', '.join(self.names)}; "
                              f"got {type(action).__name__}")
        missing = [n for n in self.names if n not in action]
        if missing:
            raise BridgeError(f"rio station '{self.name}': {who} lacks {', '.join(map(repr, missing))} (expected "
                              f"{', '.join(self.names)})")
        extra = [k for k in action if k not in self.names]
        if extra and not self._warned_extra:
            self._warned_extra = True
            log.warning("rio station '%s': ignoring %s keys not in its action: %s", self.name, who, extra)
        flat = np.empty(len(self.names))
        for i, n in enumerate(self.names):
            flat[i] = _scalar(self.name, who, n, action[n])
        bad = [n for n, v in zip(self.names, flat, strict=True) if not math.isfinite(v)]
        if bad:
            raise BridgeError(f"rio station '{self.name}': {who} {', '.join(map(repr, bad))} is NaN or infinite; "
                              "nothing was sent")
        return flat

    def send(self, action: Mapping[str, Any]) -> dict[str, float]:
        """Send one action through the embodiment (`Env.step`: each part to its node, to be reached one
        control period from now; the nodes apply limits, the step limit and the watchdog). Returns the
        targets as the nodes hold them (clipped to their joint limits and gripper range)."""
        flat = self.flat_action(action)
        self._env().step(flat)
        sent = np.clip(flat, self._lower, self._upper)
        return {n: float(v) for n, v in zip(self.names, sent, strict=True)}

    def as_dict(self, flat: Any) -> dict[str, float]:
        return {n: float(v) for n, v in zip(self.names, np.asarray(flat, dtype=np.float64).reshape(-1), strict=True)}

    def _env(self) -> Any:
        if not self.running:
            raise BridgeError(f"rio station '{self.name}' is not connected")
        return self.env


def _scalar(station: str, who: str, name: str, value: Any) -> float:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.size != 1:
        raise BridgeError(f"rio station '{station}': {who} '{name}' must be one number, got {value!r}")
    return float(arr.reshape(-1)[0])


def _one_line(message: str) -> str:
    return " ".join(line.strip() for line in message.splitlines() if line.strip())


def about(station: str, error: Exception) -> str:
    """A RIO error as one line that names the station (RIO's own messages often do already)."""
    msg = _one_line(str(error))
    return msg if str(station) in msg else f"rio station '{station}': {msg}"


def offline_embodiment(station: str, env: Any) -> Any:
    """The station's embodiment over local node objects (built as a client builds them: no server)."""
    try:
        local = {role: f.cls(f.config) for role, f in env.robot_clients.items()}
        for role, node in local.items():
            node.name = role
        return env.embodiment_cls(local, env.config)
    except Exception as e:
        raise BridgeError(f"rio station '{station}': cannot read its action layout before starting it: "
                          f"{type(e).__name__}: {e}") from e


def camera_shapes(station: str, env: Any) -> dict[str, tuple[int, int, int]]:
    """(height, width, 3) of each camera's RGB frames, from its node's declared sample layout."""
    out = {}
    for name, f in env.camera_clients.items():
        try:
            example = f.cls(f.config).example_data or {}
        except Exception as e:
            raise BridgeError(f"rio station '{station}': camera '{name}': {type(e).__name__}: {e}") from e
        rgb = example.get("rgb")
        if rgb is None:
            log.warning("rio station '%s': camera '%s' publishes no rgb; it is not a LeRobot feature", station, name)
            continue
        shape = tuple(int(x) for x in np.shape(rgb))
        if len(shape) != 3 or shape[2] != 3:
            raise BridgeError(f"rio station '{station}': camera '{name}' rgb has shape {shape}, expected (h, w, 3)")
        out[name] = (shape[0], shape[1], 3)
    return out


class _SigtermAsExit:
    """While a station runs in the main thread: SIGTERM (left at its default, which kills the process on
    the spot) raises SystemExit instead, so LeRobot's `finally` disconnects and the nodes stop cleanly."""

    def __enter__(self) -> _SigtermAsExit:
        self.old = None
        if threading.current_thread() is threading.main_thread() and \
                signal.getsignal(signal.SIGTERM) is signal.SIG_DFL:
            self.old = signal.signal(signal.SIGTERM, _exit_on_sigterm)
        return self

    def __exit__(self, *exc: Any) -> None:
        if self.old is not None and threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, self.old)


def _exit_on_sigterm(signum: int, _frame: Any) -> None:
    raise SystemExit(128 + signum)
