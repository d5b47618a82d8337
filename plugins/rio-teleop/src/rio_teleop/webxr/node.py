"""`teleop.webxr`: teleoperate from a VR/AR headset (Quest, Pico, Vision Pro) or a phone, in the browser.

The node serves an HTTPS page and a WebSocket (`server.py`); the page streams the controller's (or
hand's, or phone's) pose, clutch, trigger and buttons; `mapping.ClutchMapper` turns them into the
teleop contract (twist, gripper, buttons) that `rio teleop`'s `TwistTeleop` integrates.

`teleop.webxr_hands` (`WebXRHands`) is the same node, page and rules as a hand tracker: the page
streams both tracked hands (wrist and 25 joints, `hands` messages) and `mapping.HandMapper` publishes
them as the hand tracker contract (rio.interfaces.teleop) for `rio teleop` to retarget. See
docs/webxr.md.
"""

from __future__ import annotations

import ipaddress
import socket
import ssl
import threading
from typing import Any, Literal

from pydantic import Field, model_validator

from rio import clock
from rio.interfaces import TeleopNode
from rio.interfaces.teleop import TeleopConfig
from rio.runtime.node import remote


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def lan_addresses() -> list[str]:
    """This machine's non-loopback IPv4 addresses (best effort; sends no packet)."""
    out: list[str] = []
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.connect(("10.255.255.255", 1))  # picks the default route's address; nothing is sent
            out.append(s.getsockname()[0])
    except OSError:
        pass
    try:
        for info in socket.getaddrinfo(socket.gethostname(), None, socket.AF_INET):
            out.append(str(info[4][0]))
    except OSError:
        pass
    return [a for a in dict.fromkeys(out) if not is_loopback(a)]


class WebXRTeleop(TeleopNode):
    class Config(TeleopConfig):
        host: str = Field("127.0.0.1", description="address the page is served on: loopback by default; a LAN "
                                                    "address or 0.0.0.0 (all) needs allow_remote = true")
        port: int = Field(8443, ge=0, le=65535, description="HTTPS port (0: any free port)")
        allow_remote: bool = Field(False, description="allow serving on a non-loopback address (anyone who can "
                                                      "reach it and accepts the certificate can drive the robot)")
        cert_dir: str | None = Field(None, description="where the self-signed certificate is kept (default "
                                                       "$XDG_CONFIG_HOME/rio/webxr)")
        mapping: Literal["pose", "twist"] = Field("pose", description="pose: the tool follows the controller's "
                                                  "motion since the clutch went down; twist: the displacement "
                                                  "from there sets the tool's velocity")
        hand: Literal["right", "left"] = Field("right", description="which controller or hand drives the arm")
        scale: float = Field(1.0, gt=0, le=10, description="tool motion per controller motion (pose mapping)")
        rot_scale: float = Field(1.0, ge=0, le=10, description="tool rotation per controller rotation")
        yaw_deg: float = Field(0.0, ge=-360, le=360, description="turns the mapping about the vertical axis "
                                                                 "(operator not facing the robot's x axis)")
        max_speed: float = Field(0.15, gt=0, description="tool speed limit (m/s); keep at or below rio teleop's "
                                                        "--max-pos-speed so the tool lands on the target")
        max_rot_speed: float = Field(1.0, gt=0, description="tool rotation speed limit (rad/s)")
        gain: float = Field(20.0, gt=0, description="pose mapping: how fast the target gap closes (1/s)")
        twist_gain: float = Field(2.0, gt=0, description="twist mapping: tool speed per meter from the anchor "
                                                         "(1/s) and rad/s per rad")
        dead_band_m: float = Field(0.01, ge=0, description="twist mapping: displacement ignored (m)")
        stale_s: float = Field(0.25, gt=0, le=5, description="no message for this long: hold (watchdog)")
        silence_s: float = Field(5.0, gt=0, le=300, description="a page that sends nothing for this long (not "
                                 "even the ping it sends every 0.5 s) is disconnected, so a client that connects "
                                 "and goes silent does not keep the one operator slot (the arm held long before, "
                                 "after stale_s)")

        @model_validator(mode="after")
        def _remote_only_when_asked(self) -> WebXRTeleop.Config:
            if not is_loopback(self.host) and not self.allow_remote:
                raise ValueError(f"host {self.host!r} is not a loopback address: set allow_remote = true to "
                                 "serve the teleop page to other machines (anyone who reaches it can drive the "
                                 "robot), or keep 127.0.0.1 and forward the port (adb reverse tcp:8443 tcp:8443)")
            return self

    def setup(self) -> None:
        super().setup()
        self.url = ""
        self.fingerprint = ""
        self.robot: dict[str, Any] | None = None

    # -- lifecycle ---------------------------------------------------------------------------------
    def open(self) -> None:
        from rio.machine.keys import check_private

        from .certs import ensure_certificate
        from .server import WebXRServer

        c = self.config
        hosts = lan_addresses() if c.host in ("0.0.0.0", "::") else [c.host]
        cert = ensure_certificate(c.cert_dir, names=[*hosts, socket.gethostname()])
        check_private(cert.key)
        ctx = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
        ctx.minimum_version = ssl.TLSVersion.TLSv1_2
        ctx.load_cert_chain(str(cert.cert), str(cert.key))
        self.lock = threading.Lock()
        self.mapper = self.make_mapper()
        self.server = WebXRServer(self, c.host, c.port, ctx, silence_s=c.silence_s)
        self.server.start()
        shown = hosts or [c.host]
        self.urls = [f"https://{'localhost' if is_loopback(h) else h}:{self.server.port}/" for h in shown]
        self.url, self.fingerprint = self.urls[0], cert.fingerprint

    def make_mapper(self) -> Any:
        from .mapping import ClutchMapper

        c = self.config
        return ClutchMapper(mapping=c.mapping, scale=c.scale, rot_scale=c.rot_scale, yaw_deg=c.yaw_deg,
                            max_speed=c.max_speed, max_rot_speed=c.max_rot_speed, gain=c.gain,
                            twist_gain=c.twist_gain, dead_band_m=c.dead_band_m, stale_s=c.stale_s,
                            buttons=c.buttons)

    def close(self) -> None:
        server = getattr(self, "server", None)
        if server is not None:
            server.stop()

    def read_state(self) -> dict[str, Any]:
        with self.lock:
            return self.mapper.step(clock.now())

    # -- the server's handler (called from its thread) -------------------------------------------
    def page_config(self) -> dict[str, Any]:
        c = self.config
        return {"hand": c.hand, "mapping": c.mapping, "stale_s": c.stale_s, "fingerprint": self.fingerprint,
                "hands": False}

    def connected(self) -> None:
        with self.lock:
            self.mapper.connect(clock.now())

    def disconnected(self) -> None:
        with self.lock:
            self.mapper.disconnect(clock.now())

    def message(self, msg: dict[str, Any]) -> None:
        if msg["type"] == "input":
            with self.lock:
                self.mapper.on_input(msg, clock.now())

    def status(self) -> dict[str, Any]:
        with self.lock:
            out = self.mapper.status(clock.now())
        out["robot"] = self.robot
        return out

    # -- API -----------------------------------------------------------------------------------------
    @remote
    def help(self) -> str:
        urls = "  ".join(getattr(self, "urls", [self.url]))
        return (f"teleop.webxr: open {urls} in the headset's or phone's browser; certificate SHA-256 "
                f"{self.fingerprint} (compare before accepting it; docs/webxr.md). Hold grip (or the on-screen "
                "clutch) to move, trigger closes the gripper.")

    @remote
    def page(self) -> dict[str, Any]:
        """Where the page is: {"url", "urls", "port", "fingerprint"}."""
        return {"url": self.url, "urls": list(getattr(self, "urls", [])), "port": self.server.port,
                "fingerprint": self.fingerprint}

    @remote
    def reset(self) -> float:
        """A new run: the targets start again from where the arm is; the clutch must be pressed anew."""
        with self.lock:
            self.mapper.restart()
        return 0.0

    @remote
    def feedback(self, state: dict[str, Any]) -> None:
        """The robot's state, shown on the page's status panel (small JSON-able values: tool position,
        gripper opening). Called by whoever runs the loop; see docs/webxr.md."""
        clean: dict[str, Any] = {}
        for k, v in list(state.items())[:8]:
            try:
                many = hasattr(v, "__len__")
                clean[str(k)[:32]] = [round(float(x), 4) for x in list(v)[:8]] if many else round(float(v), 4)
            except (TypeError, ValueError):
                continue
        self.robot = clean


WebXRTeleopConfig = WebXRTeleop.Config


class WebXRHands(WebXRTeleop):
    """`teleop.webxr_hands`: the headset's tracked hands, both of them, as a hand tracker.

    The same server, certificate, page, message checks, single operator and loopback-by-default rule
    as `teleop.webxr`; the page, told `"hands": true`, streams both hands' wrist and 25 joints each XR
    frame (`hands` messages, at most `hands_hz` a second) and the node publishes them as the hand
    tracker contract (wrist_pose, hand_keypoints, tracked; twist zero; gripper from the `hand`'s pinch;
    done from the page's Finish button, held until `reset()`). `mapping`, `scale` and the speed settings do not apply:
    `rio teleop` retargets the hands (rio.teleop.hands).
    """

    hand_tracker = True

    class Config(WebXRTeleop.Config):
        hand: Literal["right", "left"] = Field("right", description="which hand's pinch drives the gripper")
        hands_hz: float = Field(60.0, ge=5, le=120, description="how often the page sends both hands (per "
                                                                "second, at most once per XR frame)")

    def make_mapper(self) -> Any:
        from .mapping import HandMapper

        c = self.config
        return HandMapper(yaw_deg=c.yaw_deg, stale_s=c.stale_s, hand=c.hand, buttons=c.buttons)

    def page_config(self) -> dict[str, Any]:
        from . import protocol

        return {**super().page_config(), "mapping": "hands", "hands": True, "hands_hz": self.config.hands_hz,
                "max_pos_m": protocol.MAX_POS_M, "max_hand_span_m": protocol.MAX_HAND_SPAN_M}

    def message(self, msg: dict[str, Any]) -> None:
        with self.lock:
            if msg["type"] == "hands":
                self.mapper.on_hands(msg, clock.now())
            elif msg["type"] == "input":
                self.mapper.on_input(msg, clock.now())

    @remote
    def help(self) -> str:
        urls = "  ".join(getattr(self, "urls", [self.url]))
        return (f"teleop.webxr_hands: open {urls} in the headset's browser; certificate SHA-256 "
                f"{self.fingerprint} (compare before accepting it; docs/webxr.md). Enter VR or AR with "
                f"hand tracking on: both hands are streamed; the {self.config.hand} hand's thumb-index "
                "pinch closes the gripper; Finish ends the run.")

    @remote
    def reset(self) -> float:
        """A new run: the hands count as tracked again once the page next sends them."""
        with self.lock:
            self.mapper.restart()
        return 0.0


WebXRHandsConfig = WebXRHands.Config
