# Hook specifications are signatures with docstrings: pluggy reads them and never calls them, so their
# bodies are empty on purpose (what mypy's empty-body check would flag in ordinary functions).
# mypy: disable-error-code="empty-body"
"""Hook specifications: what a RIO plugin can provide.

Every spec-returning hook returns a list of `Spec`s (name, kind, import path, config model, one-line
description), never an imported driver, so listing what is installed stays fast and needs no vendor
SDK. A plugin module implements any subset of these with `@rio.plugins.hookspecs.hookimpl`.
"""

from __future__ import annotations

from typing import Any

import pluggy

from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec

hookspec = pluggy.HookspecMarker("rio")
hookimpl = pluggy.HookimplMarker("rio")


@hookspec
def rio_middlewares() -> list[Spec]:
    """Middlewares (kind 'middleware'); target is a `rio.middleware.Middleware` subclass whose
    `Config` model validates the station file's `[middleware]` table."""


@hookspec
def rio_drivers() -> list[Spec]:
    """Device drivers: arm, gripper, hand, humanoid, camera, teleop, sensor, base. Target is a Node class;
    config is a pydantic model whose fields are the node's constructor keyword arguments."""


@hookspec
def rio_policies() -> list[Spec]:
    """Policies (kind 'policy'); target is a Node class hosting the model, config as for drivers."""


@hookspec
def rio_dataset_formats() -> list[Spec]:
    """Dataset formats (kind 'dataset_format') for export and import."""


@hookspec
def rio_embodiments() -> list[Spec]:
    """Embodiments (kind 'embodiment'); target is a `rio.embodiments.Embodiment` subclass. The
    embodiment of a station is inferred from the roles its class requires."""


@hookspec
def rio_stations() -> list[Spec]:
    """Packaged station files (kind 'station'); target is an absolute path of a .toml file or a
    package resource 'package:relative/path.toml' (read with importlib.resources). A renamed station
    keeps its old names in `formerly` for one release (`rio.station.load.find_station` resolves them)."""


@hookspec
def rio_workflows() -> list[Spec]:
    """Workflows (kind 'workflow'): each becomes the command `rio <name>`. Target is the command's function
    ('package.module:function', its parameters annotated for typer, its docstring the command's help), which
    runs a controller on the one control loop through `rio.workflows.run_workflow` (or several loops in one
    station session through `rio.workflows.open_session`, as `rio eval` does). RIO's own teleop, deploy,
    eval, replay and run are registered this way by the core's plugin."""


@hookspec
def rio_requirements() -> list[Requirement]:
    """What the plugin needs from the machine: optional modules (with the command that installs each)
    and system checks ('package.module:function' returning None or a one-line problem). Shown by
    `rio doctor`, grouped per plugin; modules are located with find_spec, never imported."""


@hookspec
def rio_cli(app: Any) -> Any:
    """Extra `rio` subcommands. Receives the root typer app: call `app.add_typer(sub, name="so100")`
    (so `rio so100 calibrate` works), or return a dict {name: typer.Typer} to mount."""


@hookspec
def rio_camera_listers() -> list[str]:
    """Import paths ('package.module:function') of functions that enumerate the plugin's connected
    cameras, each returning a list of `rio.plugins.cameras.CameraDevice`. Called only by `rio cameras list`
    (they may import the vendor SDK); one that raises is reported with its plugin's name."""
