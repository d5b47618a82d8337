"""rio-booster's plugin module (entry point group `rio`). Specs only: nothing here imports the SDK."""

from __future__ import annotations

from rio.hookspecs import hookimpl
from rio.specs import Spec


@hookimpl
def rio_drivers() -> list[Spec]:
    return []
