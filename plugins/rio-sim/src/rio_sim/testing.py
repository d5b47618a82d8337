"""A running sim world for tests of code that attaches to one from outside a station (emulators,
`WorldArm` users): the world node served alone, its client handed to the test."""

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
