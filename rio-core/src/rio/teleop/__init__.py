"""Teleoperation: the main loop (`run_teleop`, also `rio teleop`), arm bindings for any embodiment,
and two devices that need no hardware: `teleop.keyboard` (terminal keys) and `teleop.scripted`."""

from .loop import TeleopTick, prepare_station, run_teleop
from .summary import TeleopSummary

__all__ = ["run_teleop", "prepare_station", "TeleopTick", "TeleopSummary"]
