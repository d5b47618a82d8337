"""Plugin loading: the core's built-in plugin plus every distribution in the `rio` entry-point group."""

from __future__ import annotations

import os
from functools import lru_cache

import pluggy

from . import builtin_plugin, hookspecs
from .errors import ConfigError
from .specs import Spec


@lru_cache(maxsize=1)
def get_plugin_manager() -> pluggy.PluginManager:
    pm = pluggy.PluginManager("rio")
    pm.add_hookspecs(hookspecs)
    pm.register(builtin_plugin, name="rio-core")
    only = os.environ.get("RIO_LOAD_PLUGINS")
    if only is None:
        pm.load_setuptools_entrypoints("rio")
    else:
        for name in filter(None, (n.strip() for n in only.split(","))):
            pm.load_setuptools_entrypoints("rio", name=name)
    return pm


def specs(hook: str) -> list[Spec]:
    pm = get_plugin_manager()
    out: list[Spec] = []
    for impl_result in getattr(pm.hook, hook)():
        out.extend(impl_result or [])
    return out


def get_middleware(name: str) -> type:
    by_name = {s.name: s for s in specs("rio_middlewares")}
    if name not in by_name:
        raise ConfigError(f"unknown middleware '{name}'; registered: {sorted(by_name)}")
    return by_name[name].load()
