"""rio-teleop's plugin module (entry point group `rio`): each device's driver specs, packaged stations,
what `rio doctor` checks and the `rio gello` commands. Specs only: no device SDK is imported here."""

from __future__ import annotations

from typing import Any

from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec

from .avp import specs as avp
from .gamepad import specs as gamepad
from .gello import specs as gello
from .spacemouse import specs as spacemouse
from .webxr import specs as webxr

_DEVICES = (spacemouse, gamepad, gello, webxr, avp)


@hookimpl
def rio_drivers() -> list[Spec]:
    return [spec for device in _DEVICES for spec in device.drivers()]


@hookimpl
def rio_stations() -> list[Spec]:
    return gello.stations()


@hookimpl
def rio_requirements() -> list[Requirement]:
    return [req for device in _DEVICES for req in device.requirements()]


@hookimpl
def rio_cli(app: Any) -> None:
    from .gello.cli import app as gello_app

    app.add_typer(gello_app, name="gello")
