"""`teleop.avp`: Apple Vision Pro native hand tracking, a hand tracker on the teleop contract.

The Tracking Streamer app on the headset serves ARKit's hand tracking over gRPC (port 12345); avp-stream's
`VisionProStreamer` reads it (`sdk.Streamer`: the SDK fitted to a node). Each cycle the node turns the
SDK's newest sample into the contract (`rio.interfaces.teleop`): `wrist_pose` (2, 7), `hand_keypoints`
(2, 25, 3) in HAND_JOINTS order, `tracked` (2,), `gripper` from the `hand`'s pinch, `twist` zero,
`buttons` all false (the app sends no buttons). `rio teleop` retargets them (rio.teleop.hands).

Frames. The app sends ARKit's world frame (y up, z toward the wearer as they stood when the app started,
origin on the floor); the SDK turns it z up with YUP2ZUP, giving x right, y forward, z up (its
README's "ground frame"). The node turns that -90 degrees about z to the robot's axes: x forward (away
from the wearer), y left, z up, meters; `yaw_deg` then turns it about z for an operator who does not face
the robot's x axis. Positions and orientations are both turned (R @ p, R @ R_wrist): the orientation's
own axes stay the wrist joint's, as visionOS defines them; motions since an anchor, which is what
`rio teleop` uses, do not depend on them. Keypoints are the SDK's world-frame joints (wrist @ joint,
its `TrackingData.left/.right`), turned the same way, so keypoint 0 is the wrist's position.

Tracked. The app has no "tracked" flag: it keeps sending a lost hand's last pose. So a hand is tracked
while samples arrive (one within `stale_s`), its wrist is a rotation (an app that refuses this SDK
version sends zeros), and its wrist pose changed within `stale_s` (real tracking is never bit-for-bit
still; a lost hand is). Before a hand's first change it is not tracked (the app starts from identity).
"""

from __future__ import annotations

import ipaddress
import logging
import socket
from typing import Any, Literal

import numpy as np
from pydantic import Field, field_validator

from rio import clock
from rio.control.rotations import matrix_to_quat
from rio.errors import RioError
from rio.interfaces import NetworkDevice, TeleopNode
from rio.interfaces.teleop import HAND_JOINTS, TeleopConfig, hand_tracker_sample, pinch_opening
from rio.runtime.node import remote

from .loader import GRPC_PORT

NAME = "teleop.avp"
SIDES = ("left", "right")  # the contract's hand index: 0 left, 1 right
#: The SDK's frame (after its YUP2ZUP: x right, y forward, z up) -> the robot's (x forward, y left, z up):
#: -90 degrees about z. Times YUP2ZUP it is the WebXR mapping (rio_teleop.webxr.mapping.XR_TO_ROBOT).
SDK_TO_ROBOT = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
#: HAND_JOINTS (WebXR names) -> visionOS HandSkeleton joint names, as avp-stream's JOINT_NAMES spells them.
_FINGERS = {"index-finger": "index", "middle-finger": "middle", "ring-finger": "ring", "pinky-finger": "little"}
_PARTS = {"metacarpal": "Metacarpal", "phalanx-proximal": "Knuckle", "phalanx-intermediate": "IntermediateBase",
          "phalanx-distal": "IntermediateTip", "tip": "Tip"}
VISIONOS_JOINTS: dict[str, str] = {
    "wrist": "wrist", "thumb-metacarpal": "thumbKnuckle", "thumb-phalanx-proximal": "thumbIntermediateBase",
    "thumb-phalanx-distal": "thumbIntermediateTip", "thumb-tip": "thumbTip",
    **{f"{f}-{p}": _FINGERS[f] + _PARTS[p] for f in _FINGERS for p in _PARTS},
}
CHECKLIST = (
    "  - the Vision Pro and this machine are on the same network (the same Wi-Fi; guest networks and 'client "
    "isolation' keep devices apart)\n"
    "  - Tracking Streamer is open on the headset, started (Start), and shows 'gRPC Server Ready'\n"
    "  - ip is the address the app shows under 'Local Network' (it changes with the network)\n"
    f"  - nothing blocks TCP port {GRPC_PORT} between them (firewall, VPN)"
)
log = logging.getLogger(__name__)


def load_sdk() -> Any:
    """`rio_teleop.avp.sdk` (imports avp_stream, keeping the process's signal handlers: see `loader`)."""
    from .loader import import_avp

    import_avp("avp_stream.streamer")
    from . import sdk

    return sdk


def _is_rotation(m: np.ndarray) -> bool:
    r = m[:3, :3]
    return bool(np.isfinite(m).all() and np.allclose(r @ r.T, np.eye(3), atol=1e-3) and np.linalg.det(r) > 0)


class VisionProTeleop(TeleopNode):
    hand_tracker = True

    class Config(NetworkDevice, TeleopConfig):
        # open() waits for the first sample from the app this long
        defaults = {"connect_timeout_s": Field(10.0, gt=0, le=300)}
        ip: str = Field(description="the Vision Pro's address, as Tracking Streamer shows it under 'Local Network' "
                                    "(an IPv4 address, or a host name that resolves to one)")  # host names too
        hand: Literal["right", "left"] = Field("right", description="the hand whose pinch is the gripper")
        stale_s: float = Field(0.25, gt=0, le=5, description="no new sample, or a hand's pose unchanged, for this "
                                                             "long: that hand is not tracked")
        yaw_deg: float = Field(0.0, ge=-360, le=360, description="turns the published frame about the vertical "
                                                                 "(operator not facing the robot's x axis)")
        rate_hz: float = Field(90.0, gt=0, description="samples published per second (hand tracking runs at 90 Hz)")

        @field_validator("ip")
        @classmethod
        def _an_address(cls, v: str) -> str:
            v = v.strip()
            if not v or any(c.isspace() for c in v):
                raise ValueError("write the address Tracking Streamer shows, e.g. 192.168.1.42")
            return v

    def setup(self) -> None:
        super().setup()
        yaw = np.deg2rad(self.config.yaw_deg)
        rz = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
        self.R = rz @ SDK_TO_ROBOT
        self.streamer: Any = None
        self.address = self.config.ip
        self._reset()

    def _reset(self) -> None:
        blank = hand_tracker_sample()
        self.wrist_pose, self.keypoints = blank["wrist_pose"], blank["hand_keypoints"]
        self.valid = np.zeros(2, bool)
        self.t_moved = np.full(2, -np.inf)
        self.raw_wrist: list[np.ndarray | None] = [None, None]
        self.last_raw: Any = None
        self.gripper = 1.0

    # -- lifecycle ---------------------------------------------------------------------------------------
    def open(self) -> None:
        c = self.config
        ip = self._resolve(c.ip)
        sdk = load_sdk()
        self.address = ip if ip == c.ip else f"{c.ip} ({ip})"
        self.order = np.array([sdk.JOINT_NAMES[VISIONOS_JOINTS[j]] for j in HAND_JOINTS])
        self._reset()
        streamer = sdk.Streamer(ip)
        if not streamer.wait_first(c.connect_timeout_s):
            said = "; ".join(streamer.last_messages())
            streamer.stop(0.1)
            raise RioError(f"{NAME}: no hand tracking from the Tracking Streamer app at {self.address}:{GRPC_PORT} "
                           f"within {c.connect_timeout_s:g} s. Check:\n{CHECKLIST}"
                           + (f"\n  (avp-stream: {said})" if said else ""))
        if streamer.latest is None:  # updates came, but without hands
            streamer.stop(0.1)
            raise RioError(f"{NAME}: the Tracking Streamer app at {self.address} refuses this avp-stream version "
                           "(it sends empty updates): update both, pip install -U avp-stream and the app from "
                           "the App Store")
        self.streamer = streamer

    def close(self) -> None:
        streamer, self.streamer = self.streamer, None
        if streamer is not None and not streamer.stop(1.0):
            log.debug("%s: the SDK's gRPC thread is still in a wait; it ends when that does", self.address)

    def read_state(self) -> dict[str, Any]:
        s, c = self.streamer, self.config
        now = clock.now()
        data = s.get_latest()
        if data is not None and data.raw is not self.last_raw:  # a new sample
            self.last_raw = data.raw
            for h, side in enumerate(SIDES):
                wrist = np.asarray(data[f"{side}_wrist"], dtype=np.float64)[0]
                self.valid[h] = _is_rotation(wrist)
                if not self.valid[h]:
                    continue
                if self.raw_wrist[h] is None or not np.array_equal(wrist, self.raw_wrist[h]):
                    self.raw_wrist[h], self.t_moved[h] = wrist, now
                joints = np.asarray(getattr(data, side), dtype=np.float64)[self.order, :3, 3]  # world, SDK frame
                self.wrist_pose[h, :3] = self.R @ wrist[:3, 3]
                self.wrist_pose[h, 3:] = matrix_to_quat(self.R @ wrist[:3, :3])
                self.keypoints[h] = joints @ self.R.T
        tracked = self._tracked(now)
        driving = SIDES.index(c.hand)
        if tracked[driving]:
            self.gripper = pinch_opening(self.keypoints[driving])
        return {"twist": np.zeros(6), "gripper": float(self.gripper), "buttons": np.zeros(c.buttons, bool),
                "wrist_pose": self.wrist_pose.copy(), "hand_keypoints": self.keypoints.copy(), "tracked": tracked}

    # -- API ---------------------------------------------------------------------------------------------
    @remote
    def help(self) -> str:
        return (f"{NAME}: hand tracking from Tracking Streamer at {self.address}:{GRPC_PORT}; your "
                f"{self.config.hand} hand's pinch closes the gripper; a hand the headset loses stops its robot "
                "until it is tracked again (docs/avp.md)")

    @remote
    def status(self) -> dict[str, Any]:
        """{"address", "port", "samples", "age_s" (since the newest sample), "tracked" [left, right]}."""
        s = self.streamer
        if s is None:
            return {"address": self.address, "port": GRPC_PORT, "samples": 0, "age_s": None, "tracked": [False] * 2}
        now = clock.now()
        age = now - s.rio_t_sample
        return {"address": self.address, "port": GRPC_PORT, "samples": int(s.rio_count),
                "age_s": round(float(age), 3) if np.isfinite(age) else None,
                "tracked": [bool(t) for t in self._tracked(now)]}

    # -- inside ------------------------------------------------------------------------------------------
    def _tracked(self, now: float) -> np.ndarray:
        """Per hand: samples arrive, its wrist is a rotation, and its pose changed, all within stale_s."""
        stale = self.config.stale_s
        fresh = now - self.streamer.rio_t_sample <= stale
        return np.array([fresh and bool(self.valid[h]) and now - self.t_moved[h] <= stale for h in range(2)])

    @staticmethod
    def _resolve(ip: str) -> str:
        try:
            return str(ipaddress.IPv4Address(ip))
        except ValueError:
            pass
        try:
            infos = socket.getaddrinfo(ip, GRPC_PORT, socket.AF_INET, socket.SOCK_STREAM)
        except OSError as e:
            raise RioError(f"{NAME}: cannot resolve ip {ip!r} ({e}): write the address Tracking Streamer shows "
                           "under 'Local Network', e.g. 192.168.1.42") from None
        return str(infos[0][4][0])


VisionProTeleopConfig = VisionProTeleop.Config
