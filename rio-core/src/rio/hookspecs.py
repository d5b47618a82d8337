"""Hook specifications: what a RIO plugin can provide. Each hook returns a list of `Spec`s
(name, kind, import path, config model, one-line description), never an imported driver."""

from __future__ import annotations

import pluggy

from .specs import Spec

hookspec = pluggy.HookspecMarker("rio")
hookimpl = pluggy.HookimplMarker("rio")


@hookspec
def rio_middlewares() -> list[Spec]:
    """Middlewares (kind 'middleware'); target is a `rio.middleware.Middleware` subclass."""


@hookspec
def rio_drivers() -> list[Spec]:
    """Device drivers: arm, gripper, hand, humanoid, camera, teleop, sensor. Target is a Node class."""
