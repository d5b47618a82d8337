"""The plugin system: what plugins provide (`specs`), the hooks they implement (`hookspecs`), loading them
(`registry`), what they need from the machine (`requirements`), the core's own plugin (`builtin`), which
shipped plugin provides a name (`known`), installing them (`install`), and writing new ones (`scaffold`,
`source`, `templates/`).

This floor sits just above the foundation (`rio.errors`, `rio.config`, ...) and below the node runtime:
it knows names, kinds and import paths, never the classes behind them, so loading a plugin's entry module
imports no driver, SDK or numpy. The registry's functions are reachable here (`rio.plugins.get_registry`),
looked up on each access so that a test replacing `rio.plugins.registry.get_registry` is seen everywhere.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

__all__ = ["CORE", "ENV_ONLY", "GROUP", "OTHER_HOOKS", "PluginInfo", "Problem", "Registry", "get_middleware",
           "get_plugin_manager", "get_registry", "reset"]

if TYPE_CHECKING:
    from rio.plugins.registry import (
        CORE,
        ENV_ONLY,
        GROUP,
        OTHER_HOOKS,
        PluginInfo,
        Problem,
        Registry,
        get_middleware,
        get_plugin_manager,
        get_registry,
        reset,
    )


def __getattr__(name: str) -> Any:
    if name in __all__:
        return getattr(import_module("rio.plugins.registry"), name)
    raise AttributeError(f"module 'rio.plugins' has no attribute '{name}'")
