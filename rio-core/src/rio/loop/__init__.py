"""The one control loop every workflow runs (`ControlLoop`): cycle timing, the controller it calls each
tick, stop signals (`StopSignals`), arm tracking and the end-of-run summary (`RunSummary`).

It stands on a connected station (`rio.env.Env`) and is below the components that plug controllers into
it (`rio.teleop`, `rio.policy`, `rio.recording`) and the workflows that assemble them (`rio.workflows`).
"""

from rio.loop.control_loop import Controller, ControlLoop, Tick
from rio.loop.signals import StopSignals
from rio.loop.summary import RunSummary

__all__ = ["ControlLoop", "Controller", "Tick", "StopSignals", "RunSummary"]
