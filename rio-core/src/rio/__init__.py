"""RIO: real-time robot I/O for robot learning.

Public names are imported lazily (PEP 562): `import rio` must stay cheap, because the `rio` command
line and every plugin's entry point import this package, and `rio plugins list` must answer fast
without loading numpy, pydantic or a middleware.
"""

from __future__ import annotations

from importlib import import_module

#: typing's TYPE_CHECKING without importing typing (a few ms at the start of every `rio` command, during
#: which Ctrl-C would end in a traceback: see `rio.cli.main`); type checkers take it as typing's.
TYPE_CHECKING = False

_EXPORTS = {
    "NodeClient": ".runtime.client",
    "RioError": ".errors", "InvalidRequest": ".errors", "NodeDiedError": ".errors", "NodeError": ".errors",
    "NodeTimeout": ".errors", "QueueFull": ".errors", "TooManyConnections": ".errors",
    "ServerManager": ".runtime.manager", "ServedNode": ".runtime.manager", "connect": ".runtime.manager",
    "serve": ".runtime.manager",
    "Node": ".runtime.node", "client_side": ".runtime.node", "remote": ".runtime.node",
}

__all__ = [
    "Node", "client_side", "remote", "serve", "connect", "ServerManager", "ServedNode", "NodeClient",
    "RioError", "InvalidRequest", "NodeError", "NodeDiedError", "NodeTimeout", "QueueFull", "TooManyConnections",
]

if TYPE_CHECKING:
    from typing import Any

    from rio.errors import (
        InvalidRequest,
        NodeDiedError,
        NodeError,
        NodeTimeout,
        QueueFull,
        RioError,
        TooManyConnections,
    )
    from rio.runtime.client import NodeClient
    from rio.runtime.manager import ServedNode, ServerManager, connect, serve
    from rio.runtime.node import Node, client_side, remote


def __getattr__(name: str) -> Any:
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            value = version("rio-core")
        except PackageNotFoundError:  # running from a source tree without installation
            value = "0.0.0+unknown"
    elif name in _EXPORTS:
        value = getattr(import_module(_EXPORTS[name], __name__), name)
    else:
        raise AttributeError(f"module 'rio' has no attribute '{name}'")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_EXPORTS, "__version__"])
