"""Test helpers for code driving rio-sim worlds: a running world for code that attaches to one from
outside a station (emulators, `WorldArm` users), and the one check that a scripted pick-and-place on a
sim station did the task, from the world's ground truth."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


@contextmanager
def running_world(scene: str = "xarm7", world: str = "sim") -> Iterator[Any]:
    """Serve a `sim.world` of `scene` named `world` (thread middleware) until the block ends; yields its
    client (`get_state()`, `object_names()`, ...)."""
    from rio.manager import ServerManager
    from rio.station import make_station, parse_station

    station = parse_station({"name": f"world-{world}", "rate_hz": 30, "middleware": {"name": "thread"},
                             "components": {"world_sensor": {"driver": "sim.world", "scene": scene, "world": world}}})
    servers, clients, _ = make_station(station)
    with ServerManager(servers), clients["world_sensor"]() as client:
        yield client


def check_cube_on_pad(summary: Any, robot: str, tolerance_m: float = 0.015) -> None:
    """The world's cube (scene object "cube") was lifted, carried to the pad of `robot`'s scene and put
    down on the table, according to a teleop run's `summary` (its objects are the world's ground truth)."""
    import numpy as np

    from .robots import get_robot
    from .scenes import CUBE, PLACE_OFFSET

    assert summary.reason == "the device finished", summary.format()
    cube = next(o for o in summary.objects if o.name == "cube")
    pad = np.asarray(get_robot(robot).home_tool) + PLACE_OFFSET
    assert np.linalg.norm(cube.end[:2] - pad[:2]) < tolerance_m, summary.format()  # on the pad ...
    assert cube.max_z > cube.start[2] + 0.04, summary.format()  # ... lifted on the way ...
    assert abs(cube.end[2] - CUBE / 2) < 0.004, summary.format()  # ... and put down on the table
