"""The workflows: a station, a controller and the one control loop, assembled and run to the end.

`run_workflow` (`run`) starts a station, builds a controller on it, runs the loop and stops everything in
one order whatever happens (`open_session`); `run_teleop`, `run_deploy`, `replay_episode` and `run_eval` are
the built-in workflows behind `rio teleop`, `rio deploy`, `rio replay` and `rio eval` (a policy's trials, one
station session). This floor is above every component it assembles (`rio.teleop`, `rio.policy`,
`rio.recording`, `rio.loop`, `rio.station`) and below the command line.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

_EXPORTS = {"run_workflow": "run", "Session": "run", "open_session": "run", "run_teleop": "teleop",
            "prepare_station": "teleop", "run_deploy": "deploy", "replay_episode": "replay", "run_eval": "eval",
            "EvalResult": "eval"}
__all__ = ["EvalResult", "Session", "open_session", "prepare_station", "replay_episode", "run_deploy", "run_eval",
           "run_teleop", "run_workflow"]

if TYPE_CHECKING:
    from rio.workflows.deploy import run_deploy
    from rio.workflows.eval import EvalResult, run_eval
    from rio.workflows.replay import replay_episode
    from rio.workflows.run import Session, open_session, run_workflow
    from rio.workflows.teleop import prepare_station, run_teleop


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'rio.workflows' has no attribute '{name}'")
    value = getattr(import_module(f"rio.workflows.{_EXPORTS[name]}"), name)
    globals()[name] = value
    return value
