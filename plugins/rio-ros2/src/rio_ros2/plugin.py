"""rio-ros2's plugin module (entry point group `rio`): the `rio ros2 ...` commands and what `rio doctor`
checks. Nothing here imports zenoh or rosbags."""

from __future__ import annotations

from typing import Any

from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement


@hookimpl
def rio_cli(app: Any) -> None:
    from .cli import app as ros2

    app.add_typer(ros2, name="ros2")


@hookimpl
def rio_requirements() -> list[Requirement]:
    return [
        Requirement("zenoh", "pip install 'rio-core[zenoh]'", "`rio ros2 bridge`: the zenoh session ROS 2 peers see"),
        Requirement("rosbags", "pip install rosbags", "`rio ros2`: ROS 2 message definitions, CDR and type hashes, "
                                                      "offline"),
        Requirement("PIL", "pip install pillow", "`rio ros2 bridge --images compressed|both`: JPEG camera topics"),
    ]
