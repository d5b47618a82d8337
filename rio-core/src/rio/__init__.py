"""RIO: real-time robot I/O for robot learning.

Public names are imported lazily (PEP 562): `import rio` must stay cheap, because the `rio` command
line and every plugin's entry point import this package, and `rio plugins list` must answer fast
without loading numpy, pydantic or a middleware.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

_EXPORTS = {
    "NodeClient": ".client",
    "RioError": ".errors", "InvalidRequest": ".errors", "NodeDiedError": ".errors", "NodeError": ".errors",
    "NodeTimeout": ".errors", "QueueFull": ".errors",
    "ServerManager": ".manager", "ServedNode": ".manager", "connect": ".manager", "serve": ".manager",
    "Node": ".node", "client_side": ".node", "remote": ".node",
}

__all__ = [
    "Node", "client_side", "remote", "serve", "connect", "ServerManager", "ServedNode", "NodeClient",
    "RioError", "InvalidRequest", "NodeError", "NodeDiedError", "NodeTimeout", "QueueFull",
]

if TYPE_CHECKING:
    from .client import NodeClient
    from .errors import InvalidRequest, NodeDiedError, NodeError, NodeTimeout, QueueFull, RioError
    from .manager import ServedNode, ServerManager, connect, serve
    from .node import Node, client_side, remote


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
