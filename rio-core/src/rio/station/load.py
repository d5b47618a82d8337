"""Station files -> validated `Station`s.

Validation happens in one pass that collects every problem, each reported with the full path of the
field (`components.arm.port: required field missing`), so a user fixes a file in one go. Drivers are
looked up in the plugin registry by name; validating imports the driver's module for its `Config`
(drivers import their vendor SDKs inside `open()`, so this never needs the SDK).
"""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from rio.config import error_lines
from rio.errors import ConfigError
from rio.plugins import Registry, get_registry
from rio.station import roles as R
from rio.station.model import Component, Station, StationFile
from rio.suggest import closest, unknown
from rio.toml import parse_toml, read_text

log = logging.getLogger("rio.station")


def _looks_like_path(ref: str) -> bool:
    return ref.endswith(".toml") or os.sep in ref or "/" in ref or os.path.exists(ref)


def find_station(ref: str | os.PathLike, registry: Registry | None = None) -> Path | str:
    """Where a station given as a path or as a name registered by a plugin is: the file's path, or the
    plugin's target ('package:relative/path.toml' or an absolute path). Nothing is read.

    The one place old station names resolve (`Spec.formerly`): a name that is no station's current name
    but some station's former one finds that station, with one log line naming the new name. A current
    name wins over a former one (xarm7-emulator, formerly the name of xarm7-sim, names the emulator without
    physics now), and using it logs one line saying which station it named before."""
    if isinstance(ref, os.PathLike) or _looks_like_path(str(ref)):
        path = Path(ref)
        if not path.is_file():
            raise ConfigError(f"station file not found: {path}")
        return path
    reg = registry or get_registry()
    specs = reg.specs("rio_stations")
    stations = {s.name: s for s in specs}
    former = {old: s for s in specs for old in s.formerly}
    if ref in stations:
        if ref in former:  # a current name that was another station's: the current one wins, and says so
            _notice_once(ref, f"station '{ref}' now names {stations[ref].description or stations[ref].target}; "
                              f"the station it named until this release is '{former[ref].name}' "
                              f"({former[ref].description or former[ref].target})")
        return stations[ref].target
    if ref in former:
        new = former[ref].name
        _notice_once(ref, f"station '{ref}' is now '{new}'; the old name works until the next release")
        return former[ref].target
    raise ConfigError(unknown("station", str(ref), stations) + reg.plugin_hint("station", str(ref))
                      + " (or give the path of a .toml file)")


_noticed: set[str] = set()


def _notice_once(name: str, line: str) -> None:
    """One log line per process and renamed station: a command finds its station several times (argument
    check, load, the workflow), and says it once."""
    if name not in _noticed:
        _noticed.add(name)
        log.warning("%s", line)


def read_station_text(ref: str | os.PathLike, registry: Registry | None = None) -> tuple[str, str]:
    """(text, source) of a station given as a path or as a name registered by a plugin."""
    where = find_station(ref, registry)
    if isinstance(where, Path):
        return read_text(where), str(where)
    return read_station_resource(where)


def read_station_resource(target: str) -> tuple[str, str]:
    """Read a station spec's target: an absolute path, or 'package:relative/path.toml'."""
    if os.path.isabs(target):
        return read_text(Path(target)), target
    pkg, _, res = target.partition(":")
    from importlib.resources import files

    try:
        node = files(pkg).joinpath(res)
        return node.read_text(encoding="utf-8"), str(node)
    except (ModuleNotFoundError, FileNotFoundError, NotADirectoryError) as e:
        raise ConfigError(f"packaged station '{target}' cannot be read: {e}") from None


def load_station(ref: str | os.PathLike | Station, *, registry: Registry | None = None) -> Station:
    """A validated station from a path, a registered station name, or an existing `Station`."""
    if isinstance(ref, Station):
        return ref
    text, source = read_station_text(ref, registry)
    return parse_station(parse_toml(text, source), source=source, registry=registry)


def parse_station(data: dict[str, Any], *, source: str = "<dict>", registry: Registry | None = None) -> Station:
    """Validate the contents of a station file (already parsed). Raises one ConfigError listing all
    problems, each with its field path."""
    reg = registry or get_registry()
    try:
        top = StationFile.model_validate(data)
    except ValidationError as e:
        raise invalid(source, error_lines(e, "", StationFile)) from None
    errors: list[str] = []
    components: dict[str, Component] = {}
    for role, table in top.components.items():
        comp = resolve_component(role, table, reg, errors)
        if comp is not None:
            components[role] = comp
    _check_machines(top, errors)
    _check_wrench_sources(components, errors)
    if errors:
        raise invalid(source, errors)
    mw = top.middleware.model_dump()
    emb = top.embodiment.model_dump()
    return Station(
        name=top.name, description=top.description, rate_hz=top.rate_hz, ready_timeout_s=top.ready_timeout_s,
        components=components,
        middleware=mw.pop("name"), middleware_options=mw,
        embodiment=emb.pop("name"), embodiment_options=emb, source=source, machines=top.machines,
    )


def _check_machines(top: StationFile, errors: list[str]) -> None:
    """Each placed role exists and is placed once; machine names are key names."""
    from rio.machine.keys import NAME

    placed: dict[str, str] = {}
    for machine, sec in top.machines.items():
        where = f"machines.{machine}"
        if not NAME.match(machine) or machine == "ca":
            errors.append(f"{where}: a machine name is letters, digits, '-' and '_' (it names the machine's keys)")
        for role in sec.nodes:
            if role not in top.components:
                errors.append(f"{where}.nodes: '{role}' is not a component of this station "
                              f"({', '.join(sorted(top.components))})")
            elif role in placed:
                errors.append(f"{where}.nodes: '{role}' is already placed on machine '{placed[role]}'")
            else:
                placed[role] = machine


def _check_wrench_sources(components: dict[str, Component], errors: list[str]) -> None:
    """Each arm's `wrench_source` names a component of the station that is a wrench sensor (`WrenchNode`)."""
    from rio.interfaces.wrench import WrenchNode

    def is_wrench(comp: Component) -> bool:
        try:
            cls = comp.node_class()
        except Exception:  # its own import error was reported with its component, or is reported at start
            return False
        return isinstance(cls, type) and issubclass(cls, WrenchNode)

    wrenches = sorted(r for r, c in components.items() if R.kind_of(r) == "sensor" and is_wrench(c))
    known = f"wrench sensors here: {', '.join(wrenches)}" if wrenches else "this station has no wrench sensor"
    for role, comp in components.items():
        source = getattr(comp.config, "wrench_source", None)
        if source is None:
            continue
        where = f"components.{role}.wrench_source"
        if source not in components:
            errors.append(f"{where}: '{source}' is not a component of this station ({known})")
        elif source not in wrenches:
            errors.append(f"{where}: '{source}' is a '{components[source].driver}' {components[source].kind}, not a "
                          f"wrench sensor ({known})")


def invalid(source: str, lines: list[str]) -> ConfigError:
    return ConfigError(f"invalid station {source}:\n  " + "\n  ".join(lines))


def resolve_component(role: str, table: dict[str, Any], reg: Registry, errors: list[str]) -> Component | None:
    """One `[components.<role>]` table, validated by its driver's config; None after appending to `errors`."""
    where = f"components.{role}"
    kind = R.kind_of(role)
    if kind is None:
        best = closest(role, R.FIXED)
        hint = f"; did you mean '{best}'?" if best else ""
        errors.append(f"{where}: unknown role '{role}'{hint} roles: {R.ALL_ROLES_TEXT}")
        return None
    specs = reg.specs(R.hook_of(kind))
    of_kind = {s.name: s for s in specs if s.kind == kind}
    driver = table.get("driver")
    if not isinstance(driver, str):
        errors.append(f"{where}.driver: required field missing (a registered {kind} driver: "
                      f"{', '.join(sorted(of_kind)) or 'none installed'})")
        return None
    if driver not in of_kind:
        other = next((s for s in specs if s.name == driver), None)
        if other is not None:
            errors.append(f"{where}.driver: '{driver}' is a {other.kind} driver; role '{role}' needs a {kind} "
                          f"driver: {', '.join(sorted(of_kind)) or 'none installed'}")
        else:
            errors.append(f"{where}.driver: " + unknown(f"{kind} driver", driver, of_kind)
                          + reg.plugin_hint(kind, driver))
        return None
    spec = of_kind[driver]
    try:
        model = spec.config_model()
    except Exception as e:  # a plugin's driver module failed to import
        errors.append(f"{where}.driver: cannot load '{driver}' (plugin {spec.plugin}): {type(e).__name__}: {e}")
        return None
    if model is None:
        errors.append(f"{where}.driver: '{driver}' ({spec.target}) declares no Config (plugin {spec.plugin})")
        return None
    fields = {k: v for k, v in table.items() if k != "driver"}
    try:
        config = spec.validate(fields)
    except ValidationError as e:
        errors.extend(error_lines(e, where, model))
        return None
    except ValueError as e:  # a field contradicting the driver's preset
        errors.append(f"{where}.{e}")
        return None
    return Component(role=role, driver=driver, kind=kind, spec=spec, config=config)
