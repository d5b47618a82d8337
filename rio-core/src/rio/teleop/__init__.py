"""Teleoperation: `run_teleop` (also `rio teleop`) with its two controllers (`TwistTeleop`, `LeaderFollower`)
on the one control loop, arm bindings for any embodiment,
and two devices that need no hardware: `teleop.keyboard` (terminal keys) and `teleop.scripted`.

Exports resolve lazily: the command line imports `rio.teleop.command` while building its app, and
that must not pull numpy into `rio plugins list`."""

from __future__ import annotations

from importlib import import_module
from typing import Any

_EXPORTS = {"run_teleop": ".loop", "prepare_station": ".loop", "TwistTeleop": ".twist",
            "LeaderFollower": ".leader_follower"}

__all__ = list(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'rio.teleop' has no attribute '{name}'")
    value = getattr(import_module(_EXPORTS[name], __name__), name)
    globals()[name] = value
    return value
