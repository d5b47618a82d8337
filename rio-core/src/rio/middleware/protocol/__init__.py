"""RIO's network protocol, written once: zmq, zenoh and portal only move its bytes, subscribe and
authenticate.

- `messages`: what travels (kinds, the state stream's header, handshake, acknowledgements, calls).
- `server` / `client`: the two ends (`NetworkServer`, `NetworkClient`), which adapters subclass.
- `requests`: the server's request intake. `credits`: the client's end (a send and no wait; credits granted
  by the handshake, given back by acknowledgements). `fair`: round-robin queues with per-peer and global bounds.
- `codecs`: camera frames compressed once by the server, decoded once by each client.
- `config`: the settings every network middleware shares (`NetworkConfig`), and who may reach a node.

docs/concepts/middlewares.md describes the protocol for users.
"""

from rio.middleware.protocol.client import NetworkClient, local_process_watch
from rio.middleware.protocol.config import NetworkConfig, is_loopback, warn_if_exposed
from rio.middleware.protocol.server import NetworkServer

__all__ = ["NetworkClient", "NetworkConfig", "NetworkServer", "is_loopback", "local_process_watch",
           "warn_if_exposed"]
