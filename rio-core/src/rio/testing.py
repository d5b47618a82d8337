"""Small nodes for tests, benchmarks and plugin authors' own test suites.

They live in an importable module (not in test files) because process middlewares spawn a fresh
interpreter that must import the node class by name.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, Literal

import numpy as np
from pydantic import Field

from . import clock
from . import interfaces as ifc
from .node import Node, NodeConfig, remote


def block_import(monkeypatch: Any, *modules: str) -> None:
    """Make `import <module>` (and its submodules) fail as if the package were not installed, for a test
    of what a command says when an optional dependency is missing."""
    import builtins

    real = builtins.__import__

    def blocked(name: str, *args: Any, **kwargs: Any) -> Any:
        if any(name == m or name.startswith(m + ".") for m in modules):
            raise ImportError(f"No module named '{name}'")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", blocked)


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


def nudge_last_joint(arm: Any, rad: float = 0.1, seconds: float = 2.0, tol: float = 0.01,
                     timeout: float = 5.0) -> None:
    """A hardware test's first motion: turn an enabled arm's last joint by `rad` over `seconds` and back,
    checking it reached each goal within `tol` (rad) and `timeout` (s)."""
    q0 = np.asarray(arm.read_state()["joint_pos"], dtype=np.float64).copy()
    goal = q0.copy()
    goal[-1] += rad
    for target in (goal, q0):
        arm.command_joints(target, clock.now() + seconds)
        assert wait_until(lambda t=target: abs(arm.read_state()["joint_pos"][-1] - t[-1]) < tol, timeout=timeout)


def cycle_gripper(grip: Any, widths: Any, tol: float, seconds: float = 1.0, timeout: float = 6.0) -> None:
    """A hardware test of a gripper: command each opening in `widths` (m) in turn, arriving over `seconds`,
    checking it got within `tol` (m) of each within `timeout` (s)."""
    for goal in widths:
        grip.command("position", [goal], clock.now() + seconds)
        assert wait_until(lambda g=goal: abs(grip.read_state()["position"] - g) < tol, timeout=timeout)


def skip_tests_without(module: str, why: str, items: Any, under: str) -> None:
    """For a plugin's conftest `pytest_collection_modifyitems`: where `module` (a vendor SDK without
    wheels for this platform) is not installed, skip the tests whose path contains `under`, saying
    why, instead of failing on the import."""
    import importlib.util

    import pytest

    if importlib.util.find_spec(module) is not None:
        return
    skip = pytest.mark.skip(reason=f"{module} is not installed ({why})")
    for item in items:
        if under in str(item.path):
            item.add_marker(skip)


def run_rio(*args: str, timeout: float = 300, env: dict[str, str] | None = None) -> Any:
    """`python -m rio ARGS` in a fresh process (a command as a user types it), checked to succeed; returns
    the `subprocess.CompletedProcess` (stdout and stderr as text)."""
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-m", "rio", *args], capture_output=True, text=True, timeout=timeout,
                         stdin=subprocess.DEVNULL, env=env)
    assert out.returncode == 0, (out.stdout[-3000:], out.stderr[-3000:])
    return out


def run_scripted_square(station: str, side: float = 0.05, speed: float = 0.15) -> Any:
    """Run `station` through the real teleop loop (thread middleware) with the scripted square and check
    that its arm traced the four `side` edges and came back where it started, stage by stage: the device's
    motion as the loop took it, the arm's target (low-pass, speed limit), the commands sent, the measured
    tool; a failure names every stage's path and end, so it says which stage added or lost travel.
    Returns the run's summary. Every arm plugin's virtual station test is this one call."""
    from .teleop import run_teleop

    summary = run_teleop(station, "scripted", device_config={"script": "square", "side": side, "speed": speed},
                         middleware="thread", log=None)
    assert summary.reason == "the device finished", summary.format()
    arm = next(a for a in summary.arms if a.role == "arm")
    device, target = summary.details["travel"]["device 'teleop'"], summary.details["travel"]["arm target"]
    device_end, target_end = np.asarray(device["net_m"]), np.asarray(target["net_m"])
    measured_end = arm.end[:3] - arm.start[:3]
    stages = (f"square of {4 * side:.3f} m: device path {device['path_m']:.4f} m, ends "
              f"{np.linalg.norm(device_end) * 1000:.2f} mm from its start; target path {target['path_m']:.4f} m, "
              f"ends {np.linalg.norm(target_end) * 1000:.2f} mm; commanded path {arm.commanded_path_m:.4f} m; "
              f"measured path {arm.path_m:.4f} m, ends {np.linalg.norm(measured_end) * 1000:.2f} mm\n"
              + summary.format())
    # the device: its running total adds up to the square, closed (chords at the corners: a hair shorter; a
    # late device's twist held on for 1.5 of its sample intervals and taken back: a hair longer)
    assert np.linalg.norm(device_end) < 1e-4 and 3.6 * side < device["path_m"] < 4 * side + 0.002, stages
    # the target: the low-pass and the speed limit add and lose nothing (the device stays under the limit)
    assert np.linalg.norm(target_end - device_end) < 1e-4 and target["path_m"] <= device["path_m"] + 1e-6, stages
    # the arm, measured: four edges, a little rounding either way, and back where it started
    assert 3.6 * side < arm.path_m < 4.6 * side, stages
    assert np.linalg.norm(measured_end) < 0.003, stages
    return summary


@contextmanager
def no_new_threads() -> Iterator[None]:
    """Fail if a thread started inside the block still runs at its end: an emulator, a DDS listener or a
    bridge a test forgot to stop would otherwise keep running into the next test (a plugin conftest's
    autouse fixture: `with no_new_threads(): yield`)."""
    before = set(threading.enumerate())
    yield
    left = [t for t in threading.enumerate() if t not in before and t.is_alive()]
    assert not left, f"threads left running: {left}"


@contextmanager
def started(factory: Callable[..., Any]) -> Iterator[Callable[..., Any]]:
    """`make(**options)`: `factory(**options).start()` (an emulated robot, a simulator bridge), and every
    one made is stopped, in order, when the block ends, also after a failure (a plugin conftest's fixture:
    `with started(lambda **o: Emulator(domain_id=domain_id, **o)) as make: yield make`)."""
    made: list[Any] = []

    def make(**options: Any) -> Any:
        thing = factory(**options)
        made.append(thing)
        return thing.start()

    try:
        yield make
    finally:
        for thing in made:
            thing.stop()


@contextmanager
def lifecycle(node: Node) -> Iterator[Node]:
    """A node's server lifecycle in the caller's thread, without a middleware: `open()`, `opened()` (the
    kind's contract: limits, commander, enable), then on exit `closing()` and `close()`, exactly as the
    runtime runs them. For unit tests and hardware bring-up: `with lifecycle(Arm(port=...)) as arm:
    arm.read_state()`."""
    node.open()
    try:
        node.opened()
        yield node
    finally:
        try:
            node.closing()
        finally:
            node.close()


class Counter(Node):
    """The smallest node with state: publishes 1, 2, 3... at its rate (runtime and profiling tests)."""

    def setup(self) -> None:
        self.example_data = {"i": 0}
        self.i = 0

    def read_state(self) -> dict[str, Any]:
        self.i += 1
        return {"i": self.i}


class EchoNode(Node):
    """Publishes a counter and the last request; `echo` returns its argument (latency benchmarks)."""

    class Config(NodeConfig):
        rate_hz: float = Field(200.0, gt=0)
        payload_bytes: int = Field(2048, ge=0)
        n: int = Field(6, ge=1)

    def setup(self) -> None:
        n = self.n = self.config.n
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

    @remote
    def echo(self, payload: Any) -> Any:
        return payload

    @remote
    def fail(self, message: str, exc: str = "ValueError") -> None:
        """Raise the built-in exception named `exc` ("ValueError", "FileNotFoundError", ...) with `message`."""
        import builtins

        cls = getattr(builtins, exc, None)
        if not (isinstance(cls, type) and issubclass(cls, Exception)):
            raise ValueError(f"{exc!r} is not a built-in exception")
        raise cls(message)

    @remote
    def pid(self) -> int:
        return os.getpid()

    @remote
    def handled(self) -> list[list[int]]:
        """Every (client, seq) request handled so far, in order."""
        return [list(x) for x in self.received]

    @remote
    def sleep(self, seconds: float) -> float:
        time.sleep(seconds)
        return seconds


class ImageNode(Node):
    """Publishes HxWx3 uint8 frames as fast as its rate allows (image-streaming benchmark)."""

    class Config(NodeConfig):
        rate_hz: float = Field(30.0, gt=0)
        height: int = Field(480, ge=1)
        width: int = Field(640, ge=1)

    def setup(self) -> None:
        h, w = self.config.height, self.config.width
        self.example_data = {"rgb": np.zeros((h, w, 3), np.uint8), "frame": 0}
        self._frames = [np.full((h, w, 3), i, np.uint8) for i in range(4)]
        self.frame = 0

    def read_state(self) -> dict[str, Any]:
        self.frame += 1
        return {"rgb": self._frames[self.frame % 4], "frame": self.frame}


class FailingOpenNode(Node):
    """Raises in open(): start-up errors must reach ServerManager with the node's name."""

    def setup(self) -> None:
        self.example_data = {"x": 0.0}

    def open(self) -> None:
        raise RuntimeError("device /dev/ttyFAKE not found")


# -- Fake devices behind the standard kinds (rio.interfaces) -----------------------------------------
# In-process stand-ins with no hardware and no simulator: registered by the core as `rio.fake_*`
# drivers so stations, embodiments, docs examples and generated plugins can be exercised anywhere.
# Each one's hardware follows the goal it is written at once: the kind's commander (interpolation,
# limits, step limit, watchdog) is what makes it move smoothly, exactly as on a real driver.


class FakeArm(ifc.ArmNode):
    """Arm with joint and Cartesian control and no kinematic model. Its tool is carried by its joints
    the way a gantry's is (each joint moves it 0.1 m per rad along one axis: joint i along x, y, z for
    i mod 3 = 0, 1, 2), so the measured pose follows joint moves; an end-effector goal moves the tool
    directly and leaves the joints where they are."""

    class Config(ifc.ArmNode.Config):
        dof: int = Field(6, ge=1, le=64, description="number of joints (named joint1..N)")
        max_step_rad: float = Field(0.5, gt=0, description="largest joint goal change per cycle (rad)")
        max_step_m: float = Field(0.05, gt=0, description="largest end-effector travel per cycle (m)")
        max_step_eef_rad: float = Field(0.5, gt=0, description="largest end-effector rotation per cycle (rad)")
        frozen: bool = Field(False, description="ignore every command, as a disabled or e-stopped arm does (to "
                                                "check that a workflow notices)")

    def default_joint_names(self) -> list[str]:
        return [f"joint{i + 1}" for i in range(self.config.dof)]

    def open(self) -> None:
        home = self.config.home
        self.q = np.zeros(self.dof) if home is None else np.asarray(home, dtype=np.float64)
        #: tool travel (m) per joint motion (rad): 3 x dof
        self._carry = 0.1 * (np.arange(3)[:, None] == np.arange(self.dof)[None, :] % 3)
        self.pose = ifc.IDENTITY_POSE.copy()
        self.pose[:3] = self._carry @ self.q
        self._q_prev, self._t_prev = self.q.copy(), clock.now()

    def read_joints(self) -> dict[str, Any]:
        t = clock.now()
        vel = (self.q - self._q_prev) / max(t - self._t_prev, 1e-6)
        self._q_prev, self._t_prev = self.q.copy(), t
        return {"joint_pos": self.q.copy(), "joint_vel": vel, "eef_pose": self.pose.copy()}

    def write_joints(self, joint_pos: np.ndarray) -> None:
        if self.config.frozen:
            return
        q = np.array(joint_pos, dtype=np.float64)
        self.pose[:3] += self._carry @ (q - self.q)  # the joints carry the tool
        self.q = q

    def write_pose(self, eef_pose: np.ndarray) -> None:
        if not self.config.frozen:
            self.pose = np.array(eef_pose, dtype=np.float64)


class _FakeJoints:
    """Joints that follow the goal (the fake hand, humanoid and model arm)."""

    config: Any
    dof: int

    def default_joint_names(self) -> list[str]:
        return [f"joint{i + 1}" for i in range(self.config.dof)]

    def open(self) -> None:  # at the configured home when there is one (a pose away from singularities)
        home = self.config.home
        self.q = np.zeros(self.dof) if home is None else np.asarray(home, dtype=np.float64)

    def write_joints(self, joint_pos: np.ndarray) -> None:
        self.q = np.array(joint_pos, dtype=np.float64)


#: A 6-joint arm for tests of the kinematic part of the arm contract (simple geoms, tool site "tool"):
#: yaw, two pitches, then a spherical wrist (roll, pitch, roll). Arm straight up at zero.
SIX_DOF_MJCF = """<mujoco model="rio-test-arm">
  <compiler angle="radian" autolimits="true"/>
  <worldbody>
    <body name="base">
      <geom type="cylinder" size="0.04 0.02"/>
      <body name="l1" pos="0 0 0.05"><joint name="j1" axis="0 0 1" range="-3 3"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.1" size="0.02"/>
        <body name="l2" pos="0 0 0.1"><joint name="j2" axis="0 1 0" range="-2 2"/>
          <geom type="capsule" fromto="0 0 0 0 0 0.2" size="0.02"/>
          <body name="l3" pos="0 0 0.2"><joint name="j3" axis="0 1 0" range="-2.5 2.5"/>
            <geom type="capsule" fromto="0 0 0 0 0 0.2" size="0.02"/>
            <body name="l4" pos="0 0 0.2"><joint name="j4" axis="0 0 1" range="-3 3"/>
              <geom type="sphere" size="0.02"/>
              <body name="l5" pos="0 0 0.04"><joint name="j5" axis="0 1 0" range="-2 2"/>
                <geom type="sphere" size="0.02"/>
                <body name="l6" pos="0 0 0.04"><joint name="j6" axis="0 0 1" range="-3 3"/>
                  <geom type="box" size="0.02 0.02 0.01"/>
                  <site name="tool" pos="0 0 0.05"/>
                </body></body></body></body></body></body>
    </body>
  </worldbody>
</mujoco>"""


class FakeModelArm(_FakeJoints, ifc.ArmNode):
    """A joint-only arm that ships a robot model and measures no end-effector pose: the arm kind
    computes `eef_pose` by forward kinematics and turns end-effector targets into joint targets by IK
    (needs `rio-core[ik]`)."""

    class Config(ifc.ArmNode.Config):
        max_step_rad: float = Field(0.5, gt=0, description="largest joint goal change per cycle (rad)")

    def default_joint_names(self) -> list[str]:
        return [f"j{i + 1}" for i in range(6)]

    def default_home(self) -> list[float]:
        return [0.0, 0.5, 1.2, 0.0, 1.4, 0.0]  # tool in front of the base, pointing down

    def read_joints(self) -> dict[str, Any]:
        return {"joint_pos": self.q.copy()}

    def robot_description(self) -> dict[str, Any]:
        return {"format": "mjcf", "xml": SIX_DOF_MJCF, "frame": "tool", "frame_type": "site",
                "joints": list(self.joint_list), "home": self.default_home()}


class FakeGripper(ifc.GripperNode):
    """Parallel gripper whose fingers follow the goal; starts fully open."""

    class Config(ifc.GripperNode.Config):
        rate_hz: float = Field(100.0, gt=0)
        max_step_m: float = Field(0.05, gt=0, description="largest opening change per cycle (m)")

    def open(self) -> None:
        self.opening = self.width

    def read_width(self) -> dict[str, Any]:
        return {"position": float(self.opening)}

    def write_width(self, width: float, force: float) -> None:
        self.opening = float(width)


class FakeCamera(ifc.CameraNode):
    """Frames whose every pixel is the frame counter (mod 256); depth is a flat 1 m."""

    class Config(ifc.CameraNode.Config):
        width: int = Field(64, ge=1, le=4096)
        height: int = Field(48, ge=1, le=4096)

    def setup(self) -> None:
        super().setup()
        self.frame = 0
        w, h = self.width, self.height
        self.k = np.array([[w, 0.0, w / 2], [0.0, w, h / 2], [0.0, 0.0, 1.0]])

    def read_state(self) -> dict[str, Any]:
        self.frame += 1
        out: dict[str, Any] = {"rgb": np.full((self.height, self.width, 3), self.frame % 256, np.uint8),
                               "intrinsics": self.k}
        if self.has_depth:
            out["depth"] = np.full((self.height, self.width), 1000, np.uint16)
            out["depth_scale"] = 0.001
        return out


class FakeTeleop(ifc.TeleopNode):
    """A teleop device held still: publishes a constant twist, gripper command and released buttons."""

    class Config(ifc.TeleopNode.Config):
        twist: list[float] = Field(default_factory=lambda: [0.0] * 6, min_length=6, max_length=6,
                                   description="constant twist published (m/s, rad/s)")
        gripper: float = Field(1.0, ge=0, le=1, description="0 closed .. 1 open")
        pressed: list[int] = Field(default_factory=list, description="indices of the buttons held from the "
                                                                     "start (1 + 2: done, keep the episode)")

    def read_state(self) -> dict[str, Any]:
        buttons = np.zeros(self.config.buttons, bool)
        buttons[[i for i in self.config.pressed if i < buttons.size]] = True
        return {"twist": np.asarray(self.config.twist, dtype=np.float64), "gripper": self.config.gripper,
                "buttons": buttons}


class FakeSensor(Node):
    """A sensor of no standard kind (a force-torque sensor, say) publishing a constant reading."""

    class Config(NodeConfig):
        value: list[float] = Field(default_factory=lambda: [0.0] * 6, min_length=1, max_length=64,
                                   description="the reading published (e.g. a wrench: N, N m)")

    def setup(self) -> None:
        self.example_data = {"value": np.zeros(len(self.config.value))}

    def read_state(self) -> dict[str, Any]:
        return {"value": np.asarray(self.config.value, dtype=np.float64)}


class FakeHand(_FakeJoints, ifc.HandNode):
    """Hand whose joints follow their goal."""

    class Config(ifc.HandNode.Config):
        dof: int = Field(6, ge=1, le=64, description="number of joints (named joint1..N)")
        max_step_rad: float = Field(0.5, gt=0)

    def read_joints(self) -> dict[str, Any]:
        return {"joint_pos": self.q.copy()}


class FakeHumanoid(_FakeJoints, ifc.HumanoidNode):
    """Humanoid standing still (identity base orientation) whose joints follow their goal."""

    class Config(ifc.HumanoidNode.Config):
        dof: int = Field(12, ge=1, le=128, description="number of joints (named joint1..N)")
        rate_hz: float = Field(100.0, gt=0)
        max_step_rad: float = Field(0.5, gt=0)

    def read_joints(self) -> dict[str, Any]:
        return {"joint_pos": self.q.copy(), "joint_vel": np.zeros(self.dof),
                "base_quat": np.array([1.0, 0.0, 0.0, 0.0]), "base_ang_vel": np.zeros(3)}


# -- Fakes with kinematic models (retargeting: rio.kinematics.hand_retarget, multi_frame) ----------
# Plain capsules, no meshes. The models are written from small tables so the left hand is the right
# one mirrored by construction, and the node's joint names and limits come from the same tables.

def _vec(v: Any) -> str:
    return " ".join(f"{float(x):.6g}" for x in v)


#: Fingers of the test hand: name, knuckle (x, y) in the palm frame, phalanx lengths (proximal,
#: intermediate, distal to the tip), about 1.1 times an adult's hand.
_FINGERS = (("index", (0.095, -0.026), (0.044, 0.026, 0.022)),
            ("middle", (0.100, 0.0), (0.049, 0.030, 0.023)),
            ("ring", (0.094, 0.021), (0.046, 0.028, 0.023)),
            ("pinky", (0.085, 0.040), (0.036, 0.020, 0.021)))
_FINGER_RANGES = {"abd": (-0.35, 0.35), "mcp": (-0.3, 1.57), "pip": (0.0, 1.9), "dip": (0.0, 1.4)}
_THUMB_CMC = (0.028, -0.020, 0.012)
_THUMB_LENGTHS = (0.048, 0.035, 0.030)  # metacarpal, proximal, distal to the tip
_THUMB_RANGES = {"cmc_abd": (-0.5, 0.8), "cmc_flex": (-0.3, 1.2), "mcp": (-0.2, 1.0), "ip": (-0.3, 1.4)}


def _thumb_axes() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The thumb's rest direction (forward, toward the radial side, a little palmar), its abduction axis
    (the palm normal made perpendicular to it) and its flexion axis (turning it toward the palm)."""
    d = np.array([0.75, -0.55, 0.30])
    d /= np.linalg.norm(d)
    abd = np.array([0.0, 0.0, 1.0]) - d[2] * d
    abd /= np.linalg.norm(abd)
    return d, abd, np.cross(d, abd)


def five_finger_hand_joints() -> list[str]:
    return [*(f"thumb_{j}" for j in _THUMB_RANGES), *(f"{f}_{j}" for f, _, _ in _FINGERS for j in _FINGER_RANGES)]


def five_finger_hand_limits() -> tuple[list[float], list[float]]:
    ranges = [*_THUMB_RANGES.values(), *(r for _ in _FINGERS for r in _FINGER_RANGES.values())]
    return [lo for lo, _ in ranges], [hi for _, hi in ranges]


def five_finger_hand_mjcf(side: str = "right") -> str:
    """A 20-joint five-finger hand, written in RIO's palm frame (x wrist to middle knuckle, z out of the
    palm, y = z x x) and mounted at an arbitrary pose, so users of the model must go through its `palm`
    site. The left hand mirrors the right across the palm's xz plane: positions flip y, joint axes
    (pseudo-vectors) flip x and z, so a joint's positive direction means the same motion on both."""
    if side not in ("right", "left"):
        raise ValueError(f"side {side!r}: write 'right' or 'left'")
    left = side == "left"
    flip_pos = np.array([1.0, -1.0, 1.0]) if left else np.ones(3)
    flip_axis = np.array([-1.0, 1.0, -1.0]) if left else np.ones(3)

    def pos(v: Any) -> str:
        return _vec(flip_pos * np.asarray(v, dtype=np.float64))

    def axis(v: Any) -> str:
        return _vec(flip_axis * np.asarray(v, dtype=np.float64))

    def joint(name: str, ax: Any, rng: tuple[float, float]) -> str:
        return f'<joint name="{name}" axis="{axis(ax)}" range="{rng[0]} {rng[1]}"/>'

    def capsule(length: float, d: Any = (1.0, 0.0, 0.0), r: float = 0.009) -> str:
        return f'<geom type="capsule" fromto="0 0 0 {pos(length * np.asarray(d))}" size="{r}"/>'

    flex = (0.0, -1.0, 0.0)  # turns x toward +z: the fingers curl toward the palm
    fingers = []
    for name, (kx, ky), (l1, l2, l3) in _FINGERS:
        r = _FINGER_RANGES
        fingers.append(
            f'<site name="{name}_knuckle" pos="{pos((kx, ky, 0.0))}" size="0.004"/>'
            f'<body name="{name}_proximal" pos="{pos((kx, ky, 0.0))}">'
            f'{joint(f"{name}_abd", (0, 0, 1), r["abd"])}{joint(f"{name}_mcp", flex, r["mcp"])}{capsule(l1)}'
            f'<body name="{name}_intermediate" pos="{pos((l1, 0, 0))}">{joint(f"{name}_pip", flex, r["pip"])}'
            f'{capsule(l2)}<site name="{name}_middle" size="0.004"/>'
            f'<body name="{name}_distal" pos="{pos((l2, 0, 0))}">{joint(f"{name}_dip", flex, r["dip"])}'
            f'{capsule(l3, r=0.008)}<site name="{name}_distal" size="0.004"/>'
            f'<site name="{name}_tip" pos="{pos((l3, 0, 0))}" size="0.004"/></body></body></body>')
    d, abd, tflex = _thumb_axes()
    (t1, t2, t3), r = _THUMB_LENGTHS, _THUMB_RANGES
    thumb = (f'<body name="thumb_metacarpal" pos="{pos(_THUMB_CMC)}">'
             f'{joint("thumb_cmc_abd", abd, r["cmc_abd"])}{joint("thumb_cmc_flex", tflex, r["cmc_flex"])}'
             f'{capsule(t1, d, 0.011)}<body name="thumb_proximal" pos="{pos(t1 * d)}">'
             f'{joint("thumb_mcp", tflex, r["mcp"])}{capsule(t2, d, 0.010)}<site name="thumb_knuckle" size="0.004"/>'
             f'<body name="thumb_distal" pos="{pos(t2 * d)}">{joint("thumb_ip", tflex, r["ip"])}'
             f'{capsule(t3, d)}<site name="thumb_distal" size="0.004"/>'
             f'<site name="thumb_tip" pos="{pos(t3 * d)}" size="0.004"/></body></body></body>')
    return (f'<mujoco model="rio-test-hand-{side}"><compiler angle="radian" autolimits="true"/><worldbody>'
            # the mount: fingers along world +y, palm facing world +x (any pose would do)
            f'<body name="hand" pos="0.01 -0.02 0.05" quat="0.5 0.5 0.5 0.5">'
            f'<geom type="box" pos="{pos((0.05, 0.006, 0.0))}" size="0.05 0.045 0.012"/>'
            f'<site name="palm" size="0.005"/>{thumb}{"".join(fingers)}</body></worldbody></mujoco>')


def five_finger_hand_keypoints() -> dict[str, str]:
    """HAND_JOINTS name -> site of the test hand: every joint a finger has past its metacarpal."""
    out = {"thumb-phalanx-proximal": "thumb_knuckle", "thumb-phalanx-distal": "thumb_distal",
           "thumb-tip": "thumb_tip"}
    for name, _, _ in _FINGERS:
        human = f"{name}-finger"
        out.update({f"{human}-phalanx-proximal": f"{name}_knuckle", f"{human}-phalanx-intermediate": f"{name}_middle",
                    f"{human}-phalanx-distal": f"{name}_distal", f"{human}-tip": f"{name}_tip"})
    return out


def five_finger_hand_description(side: str = "right") -> dict[str, Any]:
    """What a dexterous hand's `robot_description()` returns (rio.kinematics.hand_retarget)."""
    return {"format": "mjcf", "xml": five_finger_hand_mjcf(side), "joints": five_finger_hand_joints(),
            "keypoints": five_finger_hand_keypoints(), "palm": "palm", "side": side}


#: The right test hand (`five_finger_hand_mjcf("left")` is its mirror image).
FIVE_FINGER_HAND_MJCF = five_finger_hand_mjcf("right")


class FakeModelHand(_FakeJoints, ifc.HandNode):
    """A 20-joint five-finger hand that ships its model, so tracked human hands can be retargeted onto
    it (needs `rio-core[ik]`); its joints follow their goal."""

    class Config(ifc.HandNode.Config):
        side: Literal["right", "left"] = Field("right", description="which hand")
        max_step_rad: float = Field(0.5, gt=0, description="largest joint goal change per cycle (rad)")

    def default_joint_names(self) -> list[str]:
        return five_finger_hand_joints()

    def hardware_limits(self) -> tuple[list[float], list[float]]:
        return five_finger_hand_limits()

    def read_joints(self) -> dict[str, Any]:
        return {"joint_pos": self.q.copy()}

    def robot_description(self) -> dict[str, Any]:
        return {**five_finger_hand_description(self.config.side), "joints": list(self.joint_list)}


_X, _Y, _Z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
#: The test humanoid's limbs, root to tip: ((joint, axis, range) at one body..., length of its link). Limbs hang
#: straight down at zero; a negative elbow angle swings the forearm forward. Ranges are the left side's.
_LEG = (((("hip_pitch", _Y, (-1.5, 1.0)), ("hip_roll", _X, (-0.3, 0.5))), 0.40), ((("knee", _Y, (0.0, 2.2)),), 0.40))
_ARM = (((("shoulder_pitch", _Y, (-2.5, 1.5)), ("shoulder_roll", _X, (-0.3, 2.2)), ("shoulder_yaw", _Z, (-2.0, 2.0))),
         0.25),
        ((("elbow", _Y, (-2.5, 0.1)),), 0.22),
        ((("wrist_yaw", _Z, (-2.5, 2.5)), ("wrist_pitch", _Y, (-1.4, 1.4)), ("wrist_roll", _X, (-1.4, 1.4))), 0.05))
_WAIST = ("waist_yaw", _Z, (-1.0, 1.0))
_ARM_HOME = {"shoulder_pitch": -0.3, "shoulder_roll": 0.15, "elbow": -1.4}
_SIDES = (("left", 1.0), ("right", -1.0))


def _limb_joints(side: str, sign: float, limb: Any) -> list[tuple[str, Any, tuple[float, float]]]:
    """(name, axis, range) of one limb's joints; roll ranges mirror on the right (a limb rolls outward on
    both sides), the others are alike."""
    out = []
    for joints, _ in limb:
        for name, ax, (lo, hi) in joints:
            out.append((f"{side}_{name}", ax, (-hi, -lo) if sign < 0 and "roll" in name else (lo, hi)))
    return out


def _upper_body_table() -> list[tuple[str, Any, tuple[float, float]]]:
    legs = [j for s, k in _SIDES for j in _limb_joints(s, k, _LEG)]
    arms = [j for s, k in _SIDES for j in _limb_joints(s, k, _ARM)]
    return [*legs, _WAIST, *arms]  # the model's own order: pelvis's subtree depth first


def upper_body_joints() -> list[str]:
    return [n for n, _, _ in _upper_body_table()]


def upper_body_limits() -> tuple[list[float], list[float]]:
    table = _upper_body_table()
    return [r[0] for _, _, r in table], [r[1] for _, _, r in table]


def upper_body_home() -> list[float]:
    """Elbows bent, forearms forward: both wrists in front of the torso, away from singularities."""
    out = []
    for joint in upper_body_joints():
        side, _, name = joint.partition("_")
        value = _ARM_HOME.get(name, 0.0) if side in ("left", "right") else 0.0
        out.append(0.0 - value if side == "right" and "roll" in name else value)
    return out


def _limb_mjcf(side: str, sign: float, attach: Any, limb: Any, end: str = "") -> str:
    xml, pos, joints = "", attach, iter(_limb_joints(side, sign, limb))
    for body_joints, length in limb:
        xml += f'<body name="{side}_{body_joints[0][0]}_link" pos="{_vec(pos)}">'
        for _ in body_joints:
            name, ax, (lo, hi) = next(joints)
            xml += f'<joint name="{name}" axis="{_vec(ax)}" range="{lo} {hi}"/>'
        xml += f'<geom type="capsule" fromto="0 0 0 0 0 {-length}" size="0.03"/>'
        pos = (0.0, 0.0, -length)
    return xml + end.format(side=side, z=pos[2]) + "</body>" * len(limb)


def _upper_body_mjcf() -> str:
    legs = "".join(_limb_mjcf(s, k, (0.0, k * 0.09, -0.05), _LEG) for s, k in _SIDES)
    arms = "".join(_limb_mjcf(s, k, (0.0, k * 0.18, 0.38), _ARM, '<site name="{side}_wrist" pos="0 0 {z}"/>')
                   for s, k in _SIDES)
    name, ax, (lo, hi) = _WAIST
    return ('<mujoco model="rio-test-humanoid"><compiler angle="radian" autolimits="true"/><worldbody>'
            '<body name="pelvis" pos="0 0 0.95"><geom type="box" size="0.08 0.12 0.06"/>'
            f'{legs}<body name="torso" pos="0 0 0.08"><joint name="{name}" axis="{_vec(ax)}" range="{lo} {hi}"/>'
            f'<geom type="capsule" fromto="0 0 0 0 0 0.35" size="0.1"/>{arms}</body></body></worldbody></mujoco>')


#: A humanoid's upper body on a fixed pelvis: two 3-joint legs (which upper-body IK must leave alone), a
#: waist yaw, and two 7-joint arms with `left_wrist` / `right_wrist` sites.
UPPER_BODY_MJCF = _upper_body_mjcf()


def upper_body_description() -> dict[str, Any]:
    """What a humanoid's `robot_description()` returns (rio.kinematics.multi_frame)."""
    return {"format": "mjcf", "xml": UPPER_BODY_MJCF, "joints": upper_body_joints(),
            "frames": {"left": "left_wrist", "right": "right_wrist"}, "frame_type": "site",
            "home": upper_body_home()}


class FakeModelHumanoid(_FakeJoints, ifc.HumanoidNode):
    """A humanoid standing still whose joints follow their goal and that ships its model
    (`UPPER_BODY_MJCF`), so its wrists can be teleoperated by IK (needs `rio-core[ik]`)."""

    class Config(ifc.HumanoidNode.Config):
        rate_hz: float = Field(100.0, gt=0)
        max_step_rad: float = Field(0.5, gt=0)

    def default_joint_names(self) -> list[str]:
        return upper_body_joints()

    def default_home(self) -> list[float]:
        return upper_body_home()

    def hardware_limits(self) -> tuple[list[float], list[float]]:
        return upper_body_limits()

    def open(self) -> None:  # ready, elbows bent: not a singular pose
        home = self.config.home if self.config.home is not None else upper_body_home()
        self.q = np.asarray(home, dtype=np.float64)

    def read_joints(self) -> dict[str, Any]:
        return {"joint_pos": self.q.copy(), "joint_vel": np.zeros(self.dof),
                "base_quat": np.array([1.0, 0.0, 0.0, 0.0]), "base_ang_vel": np.zeros(3)}

    def robot_description(self) -> dict[str, Any]:
        return {**upper_body_description(), "joints": list(self.joint_list)}


def synthetic_hand_keypoints(curl: float = 0.0, pinch: bool = False, side: str = "right") -> np.ndarray:
    """A plausible human hand's 25 keypoints (`HAND_JOINTS` order, meters) in RIO's palm frame (x from the
    wrist to the middle finger, z out of the palm, y = z x x: the thumb on -y for a right hand): fingers
    flexed by `curl` (0 open .. 1 fist), the thumb tip on the index tip when `pinch`. For tests of
    retargeting and hand-tracking teleop without a headset."""
    kp = np.zeros((25, 3))
    knuckles = ((0.090, -0.025), (0.095, -0.008), (0.088, 0.010), (0.080, 0.026))  # index, middle, ring, pinky
    bones, bends = (0.045, 0.027, 0.020), np.array([1.4, 1.6, 1.0]) * float(np.clip(curl, 0.0, 1.0))
    for k, (x, y) in enumerate(knuckles):
        i = 5 + 5 * k  # metacarpal, phalanx-proximal (knuckle), -intermediate, -distal, tip
        kp[i] = [0.02, 0.5 * y, 0.0]
        p, angle = np.array([x, y, 0.0]), 0.0
        kp[i + 1] = p
        for j, (length, bend) in enumerate(zip(bones, bends, strict=True)):
            angle += bend  # flexion turns the finger toward the palm side (+z)
            p = p + length * np.array([np.cos(angle), 0.0, np.sin(angle)])
            kp[i + 2 + j] = p
    kp[1:5] = [[0.020, -0.020, 0.010], [0.050, -0.045, 0.020], [0.075, -0.060, 0.025], [0.095, -0.070, 0.030]]
    if pinch:
        kp[4] = kp[9] + [0.0, -0.005, 0.0]
        kp[3] = 0.5 * (kp[2] + kp[4])
    if side == "left":
        kp[:, 1] *= -1.0
    return kp


class FakeHandTracker(ifc.TeleopNode):
    """A headset's hand tracking, scripted: both wrists start at `start` (the left one mirrored in y),
    then from `acquire_s` the hands are tracked, still for `still_s`, then move by `move` and turn by
    `turn_deg` about z over `seconds`, fingers curling to `curl`; optionally pinching, losing the hands,
    or pressing done."""

    hand_tracker = True

    class Config(ifc.TeleopNode.Config):
        rate_hz: float = Field(100.0, gt=0)
        hands: Literal["right", "left", "both"] = "right"
        start: list[float] = Field([0.3, -0.2, 1.0], min_length=3, max_length=3,
                                   description="right wrist at start (tracker frame, m)")
        move: list[float] = Field([0.0, 0.0, 0.0], min_length=3, max_length=3, description="wrist travel (m)")
        turn_deg: float = Field(0.0, description="wrist turn about z over the move (deg)")
        curl: float = Field(0.0, ge=0, le=1, description="finger curl reached at the end of the move")
        acquire_s: float = Field(0.2, ge=0, description="the hands are tracked from then on")
        still_s: float = Field(0.4, ge=0, description="tracked and still this long before the move starts (a "
                                                      "hand appears, then moves: the teleop anchors on it first)")
        seconds: float = Field(1.0, gt=0, description="duration of the move")
        pinch_after_s: float | None = Field(None, ge=0, description="pinch (gripper closes) from then on")
        lose_after_s: float | None = Field(None, ge=0, description="the hands are lost from then on")
        done_after_s: float | None = Field(None, ge=0, description="press done then (the run ends)")

    def open(self) -> None:
        self.t0 = clock.now()

    @remote
    def reset(self) -> float:
        self.t0 = clock.now()
        return 0.0

    def read_state(self) -> dict[str, Any]:
        from .control.rotations import quat_mul, quat_to_matrix, rotvec_to_quat

        c, t = self.config, clock.now() - self.t0
        u = float(np.clip((t - c.acquire_s - c.still_s) / c.seconds, 0.0, 1.0))
        out = ifc.teleop.hand_tracker_sample()
        on = c.acquire_s <= t and (c.lose_after_s is None or t < c.lose_after_s)
        turn = rotvec_to_quat([0.0, 0.0, np.deg2rad(c.turn_deg) * u])
        palm_down = np.array([0.0, 1.0, 0.0, 0.0])  # the palm frame's z (out of the palm) pointing down
        for side, i in (("left", ifc.teleop.LEFT), ("right", ifc.teleop.RIGHT)):
            mirror = np.array([1.0, -1.0 if side == "left" else 1.0, 1.0])
            p = np.asarray(c.start) * mirror + u * np.asarray(c.move)
            q = quat_mul(turn, palm_down)
            out["wrist_pose"][i] = np.r_[p, q]
            pinch = c.pinch_after_s is not None and t >= c.pinch_after_s
            local = synthetic_hand_keypoints(c.curl * u, pinch, side)
            out["hand_keypoints"][i] = p + local @ quat_to_matrix(q).T
            out["tracked"][i] = on and c.hands in (side, "both")
        driving = ifc.teleop.RIGHT if c.hands != "left" else ifc.teleop.LEFT
        buttons = np.zeros(c.buttons, bool)
        buttons[1:2] = c.done_after_s is not None and t >= c.done_after_s
        return {**out, "twist": np.zeros(6), "gripper": ifc.teleop.pinch_opening(out["hand_keypoints"][driving]),
                "buttons": buttons}


def fake_eef_station(name: str, teleop: str, *, dof: int = 6, gripper: bool = True, rate_hz: float = 50) -> str:
    """A teleop test station's TOML text: a fake arm in end-effector space (and a fake gripper) on the
    thread middleware, driven by the `[components.teleop]` table whose lines are `teleop` (the driver's
    line included). Append more tables (cameras) to the text as needed."""
    grip = '[components.gripper]\ndriver = "rio.fake_gripper"\nmax_width = 0.08\n' if gripper else ""
    return (f'name = "{name}"\nrate_hz = {rate_hz:g}\n[middleware]\nname = "thread"\n[embodiment]\n'
            f'action_space = "eef_pose"\n[components.arm]\ndriver = "rio.fake_arm"\ndof = {dof}\n{grip}'
            f"[components.teleop]\n{teleop.strip()}\n")


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
