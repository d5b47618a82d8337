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
from typing import Any

import numpy as np
from pydantic import Field

from rio import clock
from rio.machine.system_needs import SystemNeed
from rio.plugins.requirements import module_present
from rio.runtime.node import Node, NodeConfig, remote


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


def freeze_process(pid: int, timeout: float = 5.0) -> None:
    """SIGSTOP `pid` and wait until the kernel says it is stopped: the signal takes effect asynchronously,
    and on a loaded machine a process can still answer a call after `os.kill` returned (seen: a zenoh
    server that was to be silent replied). /proc on Linux; elsewhere a short pause."""
    import signal

    from rio.machine.host import process_state

    os.kill(pid, signal.SIGSTOP)
    if process_state(pid) is None:  # the kernel does not say (no /proc)
        time.sleep(0.05)
        return
    if not wait_until(lambda: process_state(pid) in ("T", "t"), timeout=timeout, period=0.001):
        raise TimeoutError(f"process {pid} not stopped {timeout} s after SIGSTOP")


def nudge_last_joint(arm: Any, rad: float = 0.1, seconds: float = 2.0, tol: float = 0.01,
                     timeout: float = 5.0) -> None:
    """A hardware test's first motion: turn an enabled arm's last joint by `rad` over `seconds` and back,
    checking it reached each goal within `tol` (rad) and `timeout` (s)."""
    q0 = np.asarray(arm.cycle()["joint_pos"], dtype=np.float64).copy()
    goal = q0.copy()
    goal[-1] += rad
    for target in (goal, q0):
        arm.command_joints(target, clock.now() + seconds)
        assert wait_until(lambda t=target: abs(arm.cycle()["joint_pos"][-1] - t[-1]) < tol, timeout=timeout)


def cycle_gripper(grip: Any, widths: Any, tol: float, seconds: float = 1.0, timeout: float = 6.0) -> None:
    """A hardware test of a gripper: command each opening in `widths` (m) in turn, arriving over `seconds`,
    checking it got within `tol` (m) of each within `timeout` (s)."""
    for goal in widths:
        grip.command("width", [goal], clock.now() + seconds)
        assert wait_until(lambda g=goal: abs(grip.cycle()["width"] - g) < tol, timeout=timeout)


def with_old_field_names(root: Any, renamed: Any = None) -> None:
    """Make the native dataset at `root` look recorded before its observation fields were renamed: every
    episode's steps.json names its columns by the old names (`rio.schema.RENAMED_FIELDS`, or `renamed`:
    {old: new}), and episode.json's sizes and checksums are those of the edited file, so the dataset
    verifies as one written then did. For tests that old datasets still read, replay, export and merge."""
    from pathlib import Path

    from rio.recording import paths as L
    from rio.recording.durable import describe_files, read_json, write_json_atomic
    from rio.schema import RENAMED_FIELDS

    back = {f"obs.{new}": f"obs.{old}" for old, new in (renamed or RENAMED_FIELDS).items()}
    for meta_path in sorted(Path(root).glob(f"*/{L.EPISODE_META}")):
        ep = meta_path.parent
        layout = read_json(ep / L.STEPS_SCHEMA)
        layout["fields"] = [[back.get(f[0], f[0]), *f[1:]] for f in layout["fields"]]
        write_json_atomic(ep / L.STEPS_SCHEMA, layout)
        meta = read_json(meta_path)
        meta["files"].update(describe_files(ep, [L.STEPS_SCHEMA]))
        write_json_atomic(meta_path, meta)


def skip_tests_without(need: str | SystemNeed, why: str = "", items: Any = None, under: str = "") -> None:
    """Skip the tests that cannot run here for want of `need`, saying why, instead of failing or erroring
    on it. `need` is a Python module (a vendor SDK without wheels for this platform) or a
    `rio.machine.system_needs.SystemNeed` (a library or program from a Debian package: the reason names the
    package to install).

    From a plugin conftest's `pytest_collection_modifyitems`, pass `items` and `under`: the tests whose
    path contains `under` are skipped. Without them it skips now: called at the top of a test module
    (before the import that would fail, e.g. a wheel whose extension loads the library) it skips the
    whole module, called in a test or fixture it skips that test. `pytest.importorskip` is no substitute:
    it skips only a module that is not installed, and a missing system library makes an installed one
    raise ImportError, which errors the collection."""
    import pytest

    __tracebackhide__ = True  # a skip's location is the caller's line (the test module), not this one

    if isinstance(need, SystemNeed):
        reason = need.missing()
    else:
        reason = None if module_present(need) else f"{need} is not installed"
    if reason is None:
        return
    if why:
        reason = f"{reason} ({why})"
    if items is None:
        pytest.skip(reason, allow_module_level=True)
    skip = pytest.mark.skip(reason=reason)
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
    Returns the run's summary. Every arm plugin's no-hardware station test is this one call."""
    from rio.workflows.teleop import run_teleop

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
    # the arm, measured: four edges, a little rounding either way, and back where it started. A stall of the
    # process (a loaded machine; the loop's worst lateness says how long) lets an arm that keeps its last speed
    # until the next command (Kinova's joint speeds) run on that long and come back: up to twice the stall's
    # travel at the script's speed is the stall's, not the arm's (a swing would add far more)
    stall_s = summary.lateness_us.get("max", 0.0) * 1e-6
    assert 3.6 * side < arm.path_m < 4.6 * side + 2 * speed * stall_s, stages
    assert np.linalg.norm(measured_end) < 0.003, stages
    return summary


@contextmanager
def no_new_threads(grace_s: float = 0.0) -> Iterator[None]:
    """Fail if a thread started inside the block still runs at its end: an emulator, a DDS listener or a
    bridge a test forgot to stop would otherwise keep running into the next test (a plugin conftest's
    autouse fixture: `with no_new_threads(): yield`). `grace_s`: how long threads a library ends by itself
    after its objects are released (zenoh's callback threads) may take to go."""
    before = set(threading.enumerate())
    yield

    def left() -> list[threading.Thread]:
        return [t for t in threading.enumerate() if t not in before and t.is_alive()]

    if grace_s > 0:
        wait_until(lambda: not left(), timeout=grace_s)
    assert not left(), f"threads left running: {left()}"


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
    arm.cycle()` (one tick: read, step the commander, write; `arm.read_state()` only reads)."""
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
