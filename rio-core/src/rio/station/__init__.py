"""Stations: a TOML file naming a middleware, a control rate and the components by role.

`load_station(path_or_name)` validates it; `make_station(...)` turns it into servers, client
factories and an `Env` for the inferred embodiment.
"""

from rio.station.build import ClientFactory, make_station, resolve_embodiment, resolve_middleware
from rio.station.load import load_station, parse_station
from rio.station.model import Component, Station

__all__ = ["Station", "Component", "load_station", "parse_station", "make_station", "ClientFactory",
           "resolve_middleware", "resolve_embodiment"]
