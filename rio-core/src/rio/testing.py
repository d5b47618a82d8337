"""Small nodes for tests, benchmarks and plugin authors' own test suites.

They live in an importable module (not in test files) because process middlewares spawn a fresh
interpreter that must import the node class by name.
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np

from .node import Node


def wait_until(pred: Any, timeout: float = 3.0, period: float = 0.005) -> bool:
    """Poll `pred()` until it is true or `timeout` seconds pass, and return its last value. A node's
    effect shows up a few loop ticks after the request that caused it, so tests wait for it:
    `assert wait_until(lambda: arm.get_state()["joint_pos"][0] > 0.1)`."""
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        if pred():
            return True
        time.sleep(period)
    return bool(pred())


class EchoNode(Node):
    """Publishes a counter and the last request; `echo` returns its argument (latency benchmarks)."""

    __api__ = ("get_state", "send_request", "echo", "fail", "pid", "handled", "sleep")

    def __init__(self, payload_bytes: int = 2048, rate_hz: float = 200.0, n: int = 6):
        super().__init__(rate_hz=rate_hz)
        self.payload_bytes, self.n = payload_bytes, n
        self.example_data = {"tick": 0, "q": np.zeros(n), "last": np.zeros(n)}
        self.example_request = {"q": np.zeros(n), "client": 0, "seq": 0}
        self.tick = 0
        self.last = np.zeros(n)
        self.received: list[tuple[int, int]] = []

    def read_state(self) -> dict[str, Any]:
        self.tick += 1
        return {"tick": self.tick, "q": np.full(self.n, float(self.tick)), "last": self.last}

    def handle_request(self, request: dict[str, Any]) -> None:
        self.last = np.asarray(request["q"]).copy()
        self.received.append((int(request["client"]), int(request["seq"])))

    def echo(self, payload: Any) -> Any:
        return payload

    def fail(self, message: str) -> None:
        raise ValueError(message)

    def pid(self) -> int:
        return os.getpid()

    def handled(self) -> list[list[int]]:
        """Every (client, seq) request handled so far, in order."""
        return [list(x) for x in self.received]

    def sleep(self, seconds: float) -> float:
        time.sleep(seconds)
        return seconds


class ImageNode(Node):
    """Publishes HxWx3 uint8 frames as fast as its rate allows (image-streaming benchmark)."""

    __api__ = ("get_state",)

    def __init__(self, height: int = 480, width: int = 640, rate_hz: float = 30.0):
        super().__init__(rate_hz=rate_hz)
        self.example_data = {"rgb": np.zeros((height, width, 3), np.uint8), "frame": 0}
        self._frames = [np.full((height, width, 3), i, np.uint8) for i in range(4)]
        self.frame = 0

    def read_state(self) -> dict[str, Any]:
        self.frame += 1
        return {"rgb": self._frames[self.frame % 4], "frame": self.frame}


class FailingOpenNode(Node):
    """Raises in open(): start-up errors must reach ServerManager with the node's name."""

    __api__ = ("get_state",)

    def __init__(self) -> None:
        super().__init__()
        self.example_data = {"x": 0.0}

    def open(self) -> None:
        raise RuntimeError("device /dev/ttyFAKE not found")


# -- Fake devices behind the standard interfaces (rio.interfaces) ------------------------------------
# In-process stand-ins with no hardware and no simulator: registered by the core as `rio.fake_*`
# drivers so stations, embodiments, docs examples and generated plugins can be exercised anywhere.
# Targets are reached by linear interpolation in time towards `t_cmd_target`; there is no physics and
# no kinematics (an arm's eef_pose moves only when commanded in Cartesian space).

from pydantic import Field as _Field  # noqa: E402

from . import interfaces as _ifc  # noqa: E402
from . import time as _rtime  # noqa: E402
from .config import DriverConfig as _DriverConfig  # noqa: E402


class LinearTarget:
    """A value moving linearly from where it was when commanded to a target reached at t_target."""

    def __init__(self, value: Any):
        self.value = np.array(value, dtype=np.float64)
        self._start, self._goal, self._t0, self._t1 = self.value.copy(), self.value.copy(), 0.0, 0.0

    def command(self, goal: Any, t_target: float) -> None:
        t = _rtime.now()
        self._start, self._goal = self.value.copy(), np.array(goal, dtype=np.float64)
        self._t0, self._t1 = t, max(float(t_target), t)

    def update(self) -> np.ndarray:
        t = _rtime.now()
        span = self._t1 - self._t0
        a = 1.0 if span <= 0 else min(max((t - self._t0) / span, 0.0), 1.0)
        self.value = self._start + a * (self._goal - self._start)
        return self.value


class FakeArmConfig(_DriverConfig):
    dof: int = _Field(6, ge=1, le=64, description="number of joints")
    rate_hz: float = _Field(100.0, gt=0, description="state publishing rate (Hz)")
    home: list[float] | None = _Field(None, description="initial joint positions (rad); zeros if omitted")


class FakeArm(_ifc.ArmNode):
    """Arm with joint and Cartesian targets, tracked independently (no kinematics)."""

    def __init__(self, dof: int = 6, rate_hz: float = 100.0, home: list[float] | None = None):
        super().__init__(dof, rate_hz=rate_hz)
        home_q = np.zeros(self.dof) if home is None else np.asarray(home, dtype=np.float64)
        if home_q.shape != (self.dof,):
            raise ValueError(f"home has {home_q.size} values, dof is {self.dof}")
        self.joints, self.pose = LinearTarget(home_q), LinearTarget(_ifc.IDENTITY_POSE)
        self._q_prev, self._t_prev = home_q.copy(), _rtime.now()

    def read_state(self) -> dict[str, Any]:
        t, q = _rtime.now(), self.joints.update().copy()
        vel = (q - self._q_prev) / max(t - self._t_prev, 1e-6)
        self._q_prev, self._t_prev = q, t
        return {"joint_pos": q, "joint_vel": vel, "eef_pose": self.pose.update()}

    def command_joints(self, joint_pos: np.ndarray, t_cmd_target: float) -> None:
        self.joints.command(joint_pos, t_cmd_target)

    def command_eef(self, eef_pose: np.ndarray, t_cmd_target: float) -> None:
        self.pose.command(eef_pose, t_cmd_target)


class FakeGripperConfig(_DriverConfig):
    max_width: float = _Field(0.08, gt=0, description="full opening (m)")
    rate_hz: float = _Field(100.0, gt=0)


class FakeGripper(_ifc.GripperNode):
    """Parallel gripper reaching its target opening at t_cmd_target; starts fully open."""

    def __init__(self, max_width: float = 0.08, rate_hz: float = 100.0):
        super().__init__(max_width, rate_hz=rate_hz)
        self.opening = LinearTarget(self.width)

    def read_state(self) -> dict[str, Any]:
        return {"position": float(self.opening.update()), "max_width": self.width}

    def command_position(self, position: float, t_cmd_target: float) -> None:
        self.opening.command(position, t_cmd_target)


class FakeCameraConfig(_DriverConfig):
    width: int = _Field(64, ge=1, le=4096)
    height: int = _Field(48, ge=1, le=4096)
    depth: bool = False
    rate_hz: float = _Field(30.0, gt=0)


class FakeCamera(_ifc.CameraNode):
    """Frames whose every pixel is the frame counter (mod 256); depth is a flat 1 m."""

    def __init__(self, width: int = 64, height: int = 48, depth: bool = False, rate_hz: float = 30.0):
        super().__init__(width, height, depth=depth, rate_hz=rate_hz)
        self.frame = 0
        self.k = np.array([[width, 0.0, width / 2], [0.0, width, height / 2], [0.0, 0.0, 1.0]])

    def read_state(self) -> dict[str, Any]:
        self.frame += 1
        out: dict[str, Any] = {"rgb": np.full((self.height, self.width, 3), self.frame % 256, np.uint8),
                               "intrinsics": self.k}
        if self.has_depth:
            out["depth"] = np.full((self.height, self.width), 1000, np.uint16)
            out["depth_scale"] = 0.001
        return out


class FakeTeleopConfig(_DriverConfig):
    twist: list[float] = _Field(default_factory=lambda: [0.0] * 6, min_length=6, max_length=6,
                                description="constant twist published (m/s, rad/s)")
    gripper: float = _Field(1.0, ge=0, le=1, description="0 closed .. 1 open")
    buttons: int = _Field(2, ge=0, le=32)
    rate_hz: float = _Field(100.0, gt=0)


class FakeTeleop(_ifc.TeleopNode):
    """A teleop device held still: publishes a constant twist, gripper command and released buttons."""

    def __init__(self, twist: list[float] | None = None, gripper: float = 1.0, buttons: int = 2,
                 rate_hz: float = 100.0):
        super().__init__(buttons, rate_hz=rate_hz)
        self.twist = np.zeros(6) if twist is None else np.asarray(twist, dtype=np.float64)
        self.gripper, self.n_buttons = float(gripper), int(buttons)

    def read_state(self) -> dict[str, Any]:
        return {"twist": self.twist, "gripper": self.gripper, "buttons": np.zeros(self.n_buttons, bool)}


class FakeHandConfig(_DriverConfig):
    dof: int = _Field(6, ge=1, le=64)
    rate_hz: float = _Field(100.0, gt=0)


class FakeHumanoidConfig(_DriverConfig):
    dof: int = _Field(12, ge=1, le=128)
    rate_hz: float = _Field(100.0, gt=0)


class FakeHand(_ifc.HandNode):
    """Hand whose joints reach their targets at t_cmd_target."""

    def __init__(self, dof: int = 6, rate_hz: float = 100.0):
        super().__init__(dof, rate_hz=rate_hz)
        self.joints = LinearTarget(np.zeros(self.dof))

    def read_state(self) -> dict[str, Any]:
        return {"joint_pos": self.joints.update()}

    def command_joints(self, joint_pos: np.ndarray, t_cmd_target: float) -> None:
        self.joints.command(joint_pos, t_cmd_target)


class FakeHumanoid(_ifc.HumanoidNode):
    """Humanoid standing still (identity base orientation) whose joints track their targets."""

    def __init__(self, dof: int = 12, rate_hz: float = 100.0):
        super().__init__(dof, rate_hz=rate_hz)
        self.joints = LinearTarget(np.zeros(self.dof))

    def read_state(self) -> dict[str, Any]:
        return {"joint_pos": self.joints.update(), "joint_vel": np.zeros(self.dof),
                "base_quat": np.array([1.0, 0.0, 0.0, 0.0]), "base_ang_vel": np.zeros(3)}

    def command_joints(self, joint_pos: np.ndarray, t_cmd_target: float) -> None:
        self.joints.command(joint_pos, t_cmd_target)


def write_plugin_dist(root: Any, dist: str, version: str, modules: dict[str, str],
                      entry_points: dict[str, str]) -> Any:
    """Write an importable, discoverable plugin distribution into directory `root` without installing
    anything: the modules as files plus a `<dist>-<version>.dist-info` with the `rio` entry points.
    Put `root` on sys.path (or PYTHONPATH for a subprocess) and importlib.metadata finds it, which
    lets tests exercise entry-point loading without touching the environment."""
    from pathlib import Path

    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    for name, source in modules.items():
        (root / f"{name}.py").write_text(source)
    info = root / f"{dist.replace('-', '_')}-{version}.dist-info"
    info.mkdir(exist_ok=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: {version}\n")
    eps = "".join(f"{k} = {v}\n" for k, v in entry_points.items())
    (info / "entry_points.txt").write_text(f"[rio]\n{eps}")
    return root
