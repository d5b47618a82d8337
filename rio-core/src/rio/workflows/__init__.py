"""The workflows: a station, a controller and the one control loop, assembled and run to the end.

`run_workflow` (`run`) starts a station, builds a controller on it, runs the loop and stops everything in
one order whatever happens; `run_teleop`, `run_deploy` and `replay_episode` are the built-in workflows
behind `rio teleop`, `rio deploy` and `rio replay`. This floor is above every component it assembles
(`rio.teleop`, `rio.policy`, `rio.recording`, `rio.loop`, `rio.station`) and below the command line.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

_EXPORTS = {"run_workflow": "run", "Session": "run", "run_teleop": "teleop", "prepare_station": "teleop",
            "run_deploy": "deploy", "replay_episode": "replay"}
__all__ = ["Session", "prepare_station", "replay_episode", "run_deploy", "run_teleop", "run_workflow"]

if TYPE_CHECKING:
    from rio.workflows.deploy import run_deploy
    from rio.workflows.replay import replay_episode
    from rio.workflows.run import Session, run_workflow
    from rio.workflows.teleop import prepare_station, run_teleop


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'rio.workflows' has no attribute '{name}'")
    value = getattr(import_module(f"rio.workflows.{_EXPORTS[name]}"), name)
    globals()[name] = value
    return value
