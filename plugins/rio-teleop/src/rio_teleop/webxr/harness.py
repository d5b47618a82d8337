"""Running `teleop.webxr` end to end without a headset, for tests and `bench.webxr_latency`: a station
of RIO's fake arm and gripper driven by the WebXR device through `rio.workflows.teleop.run_teleop` (the loop
`rio teleop` runs) in a background thread, and the page opened in headless Chromium (playwright),
where `window.__rioInjectPose(...)` feeds synthetic poses into the path WebXR frames take.

For `teleop.webxr_hands`: `serve_hands` runs the node alone (thread middleware) and gives a client of
what it publishes; `synthetic_hand` is a plausible 25-joint hand for `window.__rioInjectHands(left,
right)` (the path XR frames with hand tracking take) or a raw `hands_message`.
"""

from __future__ import annotations

import os
import shutil
import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from rio.machine.system_needs import SystemNeed

STATION = """\
name = "webxr-harness"
description = "fake arm + fake gripper driven by {driver}"
rate_hz = {rate_hz}

[middleware]
name = "thread"

[components.arm]
driver = "rio.fake_arm"

[components.gripper]
driver = "rio.fake_gripper"

[components.teleop]
driver = "{driver}"
port = {port}
cert_dir = "{cert_dir}"
{teleop_extra}

[embodiment]
action_space = "eef_pose"
"""

CHROMIUM_CANDIDATES = ("/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def write_station(directory: str | os.PathLike[str], *, port: int, cert_dir: str | os.PathLike[str],
                  rate_hz: float = 50, teleop_extra: str = "", driver: str = "teleop.webxr") -> Path:
    """The station: `driver` is "teleop.webxr" or "teleop.webxr_hands"."""
    path = Path(directory) / "webxr-harness.toml"
    path.write_text(STATION.format(rate_hz=rate_hz, port=port, cert_dir=os.fspath(cert_dir),
                                   teleop_extra=teleop_extra, driver=driver))
    return path


def chromium_path() -> str | None:
    env = os.environ.get("RIO_CHROMIUM")
    if env:
        return env if os.path.exists(env) else None
    for c in CHROMIUM_CANDIDATES:
        if os.path.exists(c):
            return c
    found = shutil.which("chromium")
    return found


def _no_chromium() -> str | None:
    env = os.environ.get("RIO_CHROMIUM")
    if chromium_path() is not None:
        return None
    return f"RIO_CHROMIUM={env} does not exist" if env else "no Chromium found (or set RIO_CHROMIUM to one)"


#: What the page tests in a real browser need from the system: Chromium itself, and libatomic, which
#: playwright's bundled driver (a node executable) links and Debian's chromium does not bring.
CHROMIUM = SystemNeed("chromium", probe=_no_chromium, purpose="the WebXR page in a real headless browser")
PLAYWRIGHT_DRIVER = SystemNeed("libatomic1", library="libatomic.so.1", purpose="playwright's driver (node)")


def launch_chromium(playwright: Any) -> Any:
    """Headless Chromium from the system (playwright's own download is not needed)."""
    exe = chromium_path()
    if exe is None:
        raise RuntimeError("no Chromium found (apt install chromium, or set RIO_CHROMIUM)")
    args = ["--no-sandbox"] if hasattr(os, "getuid") and os.getuid() == 0 else []
    return playwright.chromium.launch(executable_path=exe, headless=True, args=args)


def open_page(browser: Any, url: str, contexts: list[Any] | None = None, timeout_ms: int = 10_000) -> tuple[Any, Any]:
    """The teleop page in a new browser context (self-signed certificate accepted), once connected.
    The context is appended to `contexts` (for closing after a failed test)."""
    # bypass_csp: playwright's own wait_for_function evaluates strings, which the page's CSP forbids
    ctx = browser.new_context(ignore_https_errors=True, bypass_csp=True)
    if contexts is not None:
        contexts.append(ctx)
    page = ctx.new_page()
    page.goto(url)
    page.wait_for_function("window.__rioState && window.__rioState().connected", timeout=timeout_ms)
    return ctx, page


class TeleopRun:
    """`run_teleop(station)` in a thread; records the arm's measured tool pose every tick."""

    def __init__(self, station: str | os.PathLike[str], *, port: int, duration: float = 60.0, **kwargs: Any):
        self.station, self.port, self.duration, self.kwargs = os.fspath(station), port, duration, kwargs
        self.poses: list[tuple[float, np.ndarray]] = []
        self.samples: dict[float, np.ndarray] = {}  # arm sample timestamp -> eef_pose (every sample, for latency)
        self.device: dict[float, np.ndarray] = {}  # device sample timestamp -> twist, as the loop saw it
        self.lines: list[str] = []
        self.summary: Any = None
        self.error: BaseException | None = None
        self.ticks = 0
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._run, name="webxr-teleop-run", daemon=True)

    def _on_tick(self, tick: Any) -> None:
        from rio import clock

        dev = (tick.info.get("devices") or {}).get("teleop")
        if dev is not None and "timestamp" in dev:
            with self._lock:
                self.device.setdefault(float(dev["timestamp"]), np.asarray(dev["twist"]).copy())
        arms = tick.info.get("arms") or []
        if arms:
            s = arms[0].client.get_state(k=16)
            with self._lock:
                for ts, pose in zip(np.asarray(s["timestamp"]), np.asarray(s["eef_pose"]), strict=True):
                    self.samples.setdefault(float(ts), pose.copy())
                self.poses.append((clock.now(), np.asarray(s["eef_pose"])[-1].copy()))
        self.ticks += 1

    def _run(self) -> None:
        from rio.workflows.teleop import run_teleop

        try:
            self.summary = run_teleop(self.station, duration=self.duration, on_tick=self._on_tick,
                                      log=self.lines.append, **self.kwargs)
        except BaseException as e:  # noqa: BLE001 - re-raised by the caller through check()
            self.error = e

    def start(self, timeout: float = 30.0) -> TeleopRun:
        self._thread.start()
        t_end = time.monotonic() + timeout
        while time.monotonic() < t_end:
            self.check()
            if self.ticks > 2:
                return self
            time.sleep(0.05)
        raise TimeoutError(f"the teleop run did not start within {timeout:g} s: {self.lines[-5:]}")

    def check(self) -> None:
        if self.error is not None:
            raise self.error
        if not self._thread.is_alive() and self.summary is None and self.ticks:
            raise RuntimeError(f"the teleop run ended: {self.lines[-5:]}")

    @property
    def url(self) -> str:
        return f"https://localhost:{self.port}/"

    def eef(self) -> np.ndarray:
        with self._lock:
            return self.poses[-1][1].copy()

    def wait_for(self, pred: Any, timeout: float = 5.0) -> np.ndarray:
        """The tool pose once `pred(pose)` holds (TimeoutError otherwise)."""
        t_end = time.monotonic() + timeout
        while time.monotonic() < t_end:
            self.check()
            pose = self.eef()
            if pred(pose):
                return pose
            time.sleep(0.02)
        raise TimeoutError(f"the arm did not get there within {timeout:g} s (at {self.eef()[:3]})")

    def wait_still(self, timeout: float = 5.0, window: float = 0.3, tol: float = 2e-4) -> np.ndarray:
        """The tool pose once it has moved less than `tol` over `window` seconds."""
        t_end = time.monotonic() + timeout
        while time.monotonic() < t_end:
            self.check()
            with self._lock:
                now = self.poses[-1][0]
                recent = [p for t, p in self.poses if t > now - window]
            if len(recent) > 3 and np.ptp(np.stack(recent)[:, :3], axis=0).max() < tol:
                return recent[-1].copy()
            time.sleep(0.05)
        raise TimeoutError(f"the arm did not settle within {timeout:g} s (at {self.eef()[:3]})")

    def join(self, timeout: float = 30.0) -> Any:
        self._thread.join(timeout)
        if self._thread.is_alive():
            raise TimeoutError("the teleop run did not end")
        if self.error is not None:
            raise self.error
        return self.summary


def input_message(p: Any = None, q: Any = (0.0, 0.0, 0.0, 1.0), *, clutch: bool = False, trigger: float = 0.0,
                  seq: int = 0, mode: bool = False, done: bool = False) -> dict[str, Any]:
    """An `input` message as the page sends it (WebXR reference space: y up, -z forward)."""
    pose = None if p is None else {"p": [float(x) for x in p], "q": [float(x) for x in q]}
    return {"type": "input", "seq": seq, "t": 0.0, "source": "test", "pose": pose, "clutch": clutch,
            "trigger": trigger, "mode": mode, "done": done}


def finish(port: int, timeout: float = 5.0) -> None:
    """Press the page's Finish button from a raw WebSocket client (ends a `rio teleop` run)."""
    import asyncio
    import json
    import ssl

    async def go() -> None:
        import aiohttp

        ctx = ssl.create_default_context()
        ctx.check_hostname, ctx.verify_mode = False, ssl.CERT_NONE
        sent = False
        while not sent:  # the previous operator's page may still be going away (then this one is told 'busy')
            try:
                async with aiohttp.ClientSession() as s, s.ws_connect(f"wss://localhost:{port}/ws", ssl=ctx) as ws:
                    first = json.loads(await ws.receive_str())
                    if first.get("type") != "config":  # busy: another page is connected
                        raise ConnectionError(first.get("message"))
                    sent = True
                    for _ in range(5):
                        await ws.send_str(json.dumps(input_message(done=True)))
                        await asyncio.sleep(0.05)
            except (aiohttp.ClientError, ConnectionError):
                if not sent:  # once sent, the run ending closes the socket under us: done
                    await asyncio.sleep(0.2)

    errors: list[BaseException] = []

    def in_thread() -> None:  # its own event loop (the caller may be inside one: playwright's sync API)
        try:
            asyncio.run(asyncio.wait_for(go(), timeout))
        except BaseException as e:  # noqa: BLE001 - re-raised below
            errors.append(e)

    t = threading.Thread(target=in_thread)
    t.start()
    t.join(timeout + 1)
    if errors:
        raise errors[0]


# -- teleop.webxr_hands ----------------------------------------------------------------------------------
def synthetic_hand(wrist: Any = (0.0, 1.2, -0.3), q: Any = (0.0, 0.0, 0.0, 1.0), *, pinch_m: float = 0.05,
                   ) -> dict[str, Any]:
    """A hand as the page sends it (WebXR reference space, y up, -z forward): 25 joints in HAND_JOINTS
    order, the wrist at `wrist`, fingers along the wrist's -z, thumb tip `pinch_m` from the index tip;
    the whole hand turned by `q` (x, y, z, w) about the wrist, which is also the wrist's orientation."""
    from rio.control.rotations import quat_rotate
    from rio.interfaces.teleop import HAND_JOINTS

    local = np.zeros((len(HAND_JOINTS), 3))
    for k in range(4):  # index, middle, ring, pinky: metacarpal .. tip, spread along x
        for part in range(5):
            local[5 + 5 * k + part] = [-0.03 + 0.02 * k, 0.0, -(0.03 + 0.02 * part)]
    index_tip = local[HAND_JOINTS.index("index-finger-tip")]
    for part in range(4):  # thumb: metacarpal .. tip, ending pinch_m to the index tip's left
        local[1 + part] = (part + 1) / 4 * (index_tip + [-pinch_m, 0.0, 0.0])
    x, y, z, w = (float(v) for v in q)
    joints = np.asarray(wrist, dtype=np.float64) + quat_rotate([w, x, y, z], local)
    return {"j": joints.tolist(), "q": [x, y, z, w]}


def hands_message(left: dict[str, Any] | None = None, right: dict[str, Any] | None = None, *,
                  seq: int = 0) -> dict[str, Any]:
    """A `hands` message as the page sends it (see rio_teleop.webxr.protocol)."""
    return {"type": "hands", "seq": seq, "t": 0.0, "left": left, "right": right}


@contextmanager
def serve_hands(cert_dir: str | os.PathLike[str], *, port: int = 0, rate_hz: float = 100,
                **config: Any) -> Iterator[Any]:
    """`teleop.webxr_hands` served alone (thread middleware): yields a client of the node (its
    `get_state()` is what it publishes, `page()` where the page is)."""
    from rio.runtime.manager import ServerManager, connect, serve

    from .node import WebXRHands

    cfg = {"port": port, "cert_dir": os.fspath(cert_dir), "rate_hz": rate_hz, **config}
    with ServerManager("thread", [serve(WebXRHands, name="teleop", **cfg)]), \
            connect(WebXRHands, "thread", name="teleop", **cfg) as client:
        yield client
