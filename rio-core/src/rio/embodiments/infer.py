"""Which embodiment a station gets: the registered embodiment whose required roles are all present,
the most specific one (most required roles) winning; or the one the station names."""

from __future__ import annotations

from rio.errors import ConfigError
from rio.plugins import Problem, Registry, get_registry
from rio.plugins.specs import Spec


def _required(spec: Spec, reg: Registry) -> frozenset[str] | None:
    try:
        return frozenset(spec.load().required_roles)
    except Exception as e:  # a plugin's embodiment that fails to import cannot be chosen; say so
        reg.report(Problem(spec.plugin, f"embodiment '{spec.name}' cannot be loaded: {type(e).__name__}: {e}"))
        return None


def infer_embodiment(roles: set[str], name: str | None = None, registry: Registry | None = None) -> Spec | None:
    """The embodiment spec for these roles; None when no embodiment applies (e.g. a teleop-only station)."""
    reg = registry or get_registry()
    if name is not None:
        spec = reg.find("rio_embodiments", name, "embodiment")
        req = spec.load().required_roles
        if not set(req) <= roles:
            raise ConfigError(f"embodiment.name: '{name}' needs roles {sorted(req)}; the station has {sorted(roles)}")
        return spec
    matches: list[tuple[int, Spec]] = []
    for spec in reg.specs("rio_embodiments"):
        req = _required(spec, reg)
        if req and req <= roles:
            matches.append((len(req), spec))
    if not matches:
        return None
    best = max(n for n, _ in matches)
    top = [s for n, s in matches if n == best]
    if len(top) > 1:
        raise ConfigError(f"roles {sorted(roles)} fit several embodiments equally: {[s.name for s in top]}; "
                          "choose one with [embodiment] name = \"...\"")
    return top[0]
