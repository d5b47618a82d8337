"""Changing a validated station: another teleop device (`rio teleop --teleop`), a device's fields over the
file's (`--teleop-set`), the policy component taken out (`rio deploy` starts the policy node itself).

Every change is made on a `Station` that was already validated, and only the changed component is validated
again, by the same code that validated the file (`rio.station.load.resolve_component`): a malformed file is
refused, naming its fields, before any option is applied to it, and an option is checked like a line of the
file it stands for.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from rio.errors import ConfigError
from rio.plugins import Registry, get_registry
from rio.station.load import invalid, resolve_component
from rio.station.model import Station


def with_component(st: Station, role: str, driver: str | None = None, fields: dict[str, Any] | None = None, *,
                   registry: Registry | None = None) -> Station:
    """`st` with `role` served by `driver` (None: the component's own) configured by `fields` over the
    component's own fields when the driver stays the same (a new driver starts from its defaults)."""
    old = st.components.get(role)
    driver = driver or (old.driver if old is not None else None)
    if driver is None:
        raise ConfigError(f"{st.source}: no {role} component to configure; name its driver")
    keep = old.config.model_dump(exclude_unset=True) if old is not None and old.driver == driver else {}
    errors: list[str] = []
    comp = resolve_component(role, {**keep, **(fields or {}), "driver": driver}, registry or get_registry(), errors)
    if comp is None:
        raise invalid(st.source, errors)
    return dataclasses.replace(st, components={**st.components, role: comp})


def without_role(st: Station, role: str) -> Station:
    """`st` without its `role` component (unchanged when it has none)."""
    return dataclasses.replace(st, components={r: c for r, c in st.components.items() if r != role})


def teleop_driver(name: str, registry: Registry | None = None) -> str:
    """A teleop device as a user types it: 'scripted' -> 'teleop.scripted' when that is a registered teleop
    driver; a name with a dot as given."""
    if "." in name:
        return name
    teleops = {s.name for s in (registry or get_registry()).specs("rio_drivers") if s.kind == "teleop"}
    return f"teleop.{name}" if f"teleop.{name}" in teleops else name


def with_teleop(st: Station, device: str | None = None, fields: dict[str, Any] | None = None, *,
                registry: Registry | None = None) -> Station:
    """`st` driven by `device` (`teleop_driver` names) and/or with `fields` over its teleop device's own."""
    if device is None and not fields:
        return st
    if device is None and "teleop" not in st.components:
        raise ConfigError(f"{st.source}: no teleop component; pass a device (--teleop keyboard or --teleop scripted)")
    driver = teleop_driver(device, registry) if device else None
    return with_component(st, "teleop", driver, fields, registry=registry)
