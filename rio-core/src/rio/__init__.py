"""RIO: real-time robot I/O for robot learning."""

from importlib.metadata import PackageNotFoundError, version

from .client import NodeClient
from .errors import InvalidRequest, NodeDiedError, NodeError, NodeTimeout, QueueFull, RioError
from .manager import ServerManager, ServerSpec, connect, serve
from .node import Node, client_side

try:
    __version__ = version("rio-core")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

__all__ = [
    "Node", "client_side", "serve", "connect", "ServerManager", "ServerSpec", "NodeClient",
    "RioError", "InvalidRequest", "NodeError", "NodeDiedError", "NodeTimeout", "QueueFull",
]
