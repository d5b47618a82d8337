"""Teleoperation: the controllers `rio teleop` (`rio.workflows.teleop`) plugs into the one control loop
(`TwistTeleop` for twist devices, `LeaderFollower` for leader arms, `HandTeleop` for hand trackers), arm
bindings for any embodiment, hand retargeting, and two devices that need no hardware: `teleop.keyboard`
(terminal keys) and `teleop.scripted`.

Exports resolve lazily: the command line imports `rio.cli.teleop_cmd` while building its app, and
that must not pull numpy into `rio plugins list`."""

from __future__ import annotations

from importlib import import_module
from typing import Any

_EXPORTS = {"TwistTeleop": ".twist", "LeaderFollower": ".leader_follower", "HandTeleop": ".hands"}

__all__ = list(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'rio.teleop' has no attribute '{name}'")
    value = getattr(import_module(_EXPORTS[name], __name__), name)
    globals()[name] = value
    return value
