"""The WebXR teleop's specs, for rio-teleop's plugin module (`rio_teleop.plugin`)."""

from __future__ import annotations

from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec


def drivers() -> list[Spec]:
    return [Spec("teleop.webxr", "teleop", "rio_teleop.webxr.node:WebXRTeleop",
                 "VR/AR headsets (Quest, Pico, Vision Pro) and phones in the browser: HTTPS page + WebSocket, "
                 "clutch, pose or twist mapping"),
            Spec("teleop.webxr_hands", "teleop", "rio_teleop.webxr.node:WebXRHands",
                 "both tracked hands (wrist + 25 joints) from a headset's browser (Quest, Pico, Vision Pro "
                 "WebXR hand input), as a hand tracker for arms, humanoid wrists and dexterous hands")]


def requirements() -> list[Requirement]:
    return [
        Requirement("aiohttp", "pip install rio-teleop", "teleop.webxr: the HTTPS page and its WebSocket"),
        Requirement("cryptography", "pip install 'rio-core[keys]'", "teleop.webxr: its self-signed certificate"),
    ]
