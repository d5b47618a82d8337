"""One ROS 2 node on a zenoh session, in rmw_zenoh's wire format, so ROS 2 machines running rmw_zenoh
(`RMW_IMPLEMENTATION=rmw_zenoh_cpp`) see it in their graph and exchange messages with it.

What rmw_zenoh expects, and what this module does:

- data: a message is its CDR bytes (with the encapsulation header) put on
  `<domain>/<topic without leading slash>/<pkg>::msg::dds_::<Type>_/<type hash>`, with an attachment
  carrying the publisher's sequence number, source timestamp (ns) and 16-byte GID, serialized by
  zenoh's own serializer (int64, int64, bytes);
- discovery: liveliness tokens under `@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<kind>/<enclave>/
  <namespace>/<node name>[/<topic>/<type>/<hash>/<qos>]` (kinds NN node, MP publisher, MS
  subscription; every '/' inside a name written as '%'), alive exactly as long as the entity.

The session is a zenoh peer like rmw_zenoh's: it connects to the endpoints given (by default a
router on this machine, `tcp/127.0.0.1:7447`, what `ros2 run rmw_zenoh_cpp rmw_zenohd` listens on),
listens on loopback, and never scouts by multicast. A router that is not up yet is retried in the
background, so the node starts either way. With a machine's keys every link is mutual TLS with the
station's CA (`security`).
"""

from __future__ import annotations

import hashlib
import json
import logging
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from .messages import MessageTypes, dds_name

log = logging.getLogger("rio.ros2")

ADMIN = "@ros2_lv"
#: rmw_zenoh's QoS field of a token: reliable, volatile, keep last 10 (the ROS 2 default profile).
DEFAULT_QOS = "::,10:,:,:,,"
DEFAULT_CONNECT = ("tcp/127.0.0.1:7447",)
DEFAULT_LISTEN = ("tcp/127.0.0.1:0",)


def mangle(name: str) -> str:
    return name.replace("/", "%") if name else "%"


def session_config(connect: Sequence[str], listen: Sequence[str], keys: Any = None, domain: int = 0) -> Any:
    """The session's zenoh config; with `keys` (`rio.machine.keys.MachineKeys`) every link is mutual TLS
    (`tcp/` endpoints become `tls/`) and only machines the keys trust exchange the domain's traffic."""
    import zenoh

    c = zenoh.Config()
    c.insert_json5("mode", '"peer"')
    c.insert_json5("scouting/multicast/enabled", "false")
    if keys is not None:
        from rio.middleware.zenoh import secure_links, tls_endpoints

        from .security import ROS_MESSAGES, key_exprs

        connect, listen = tls_endpoints(list(connect)), tls_endpoints(list(listen))
        for path, value in secure_links(keys, key_exprs(domain), ROS_MESSAGES).items():
            c.insert_json5(path, json.dumps(value))
    c.insert_json5("connect/endpoints", json.dumps(list(connect)))
    c.insert_json5("listen/endpoints", json.dumps(list(listen)))
    return c


class Publisher:
    def __init__(self, node: RosNode, topic: str, msg_type: str, entity_id: int):
        self.node, self.topic, self.msg_type = node, topic, msg_type
        self.keyexpr, token = node.keyexprs(topic, msg_type, entity_id, "MP")
        self.gid = hashlib.sha256(token.encode()).digest()[:16]  # as rmw_zenoh: a hash of the entity's token
        self._pub = node.session.declare_publisher(self.keyexpr)
        self._token = node.liveliness.declare_token(token)
        self.seq = 0
        self.count = 0

    def publish(self, msg: Any) -> None:
        from zenoh.ext import Int64, z_serialize

        self.seq += 1
        attachment = z_serialize((Int64(self.seq), Int64(time.time_ns()), self.gid))
        self._pub.put(self.node.types.serialize(msg, self.msg_type), attachment=attachment)
        self.count += 1

    def close(self) -> None:
        self._token.undeclare()
        self._pub.undeclare()


class Subscription:
    """Calls `callback(msg)` on a zenoh thread for each message. A peer's bytes are never trusted: a
    payload over `max_bytes` or not a valid message is dropped, logged the first time, counted."""

    def __init__(self, node: RosNode, topic: str, msg_type: str, entity_id: int, callback: Callable[[Any], None],
                 max_bytes: int = 1 << 20):
        self.node, self.topic, self.msg_type, self.callback = node, topic, msg_type, callback
        self.keyexpr, token = node.keyexprs(topic, msg_type, entity_id, "MS")
        self.max_bytes = int(max_bytes)
        self.dropped = 0
        self._sub = node.session.declare_subscriber(self.keyexpr, self._on_sample)
        self._token = node.liveliness.declare_token(token)

    def _drop(self, why: str) -> None:
        self.dropped += 1
        if self.dropped == 1:
            log.warning("%s: a message was dropped (%s); further ones are counted, not logged", self.topic, why)

    def _on_sample(self, sample: Any) -> None:
        data = sample.payload.to_bytes()
        if len(data) > self.max_bytes:
            self._drop(f"{len(data)} bytes, more than {self.max_bytes}")
            return
        try:
            msg = self.node.types.deserialize(data, self.msg_type)
        except Exception as e:  # never raised into zenoh's thread
            self._drop(f"not a valid {self.msg_type}: {type(e).__name__}: {e}")
            return
        try:
            self.callback(msg)
        except Exception as e:
            self._drop(f"{type(e).__name__} while handling it: {e}")
            log.debug("%s: handling a message failed", self.topic, exc_info=True)

    def close(self) -> None:
        self._token.undeclare()
        self._sub.undeclare()


class RosNode:
    """A ROS 2 node `namespace/name` in `domain`: `publisher(topic, type)`, `subscription(topic, type, cb)`.
    Topic names are absolute (`/arm/joint_states`). A context manager; `close()` withdraws it from
    the graph."""

    def __init__(self, name: str, *, namespace: str = "/", domain: int = 0, types: MessageTypes,
                 connect: Sequence[str] = DEFAULT_CONNECT, listen: Sequence[str] = DEFAULT_LISTEN, keys: Any = None):
        import zenoh

        if not 0 <= int(domain) <= 232:
            raise ValueError(f"ROS domain id must be 0..232, got {domain}")
        self.name, self.namespace, self.domain, self.types = name, namespace, int(domain), types
        try:
            self.session = zenoh.open(session_config(connect, listen, keys, self.domain))
        except zenoh.ZError as e:
            from rio.errors import ConfigError

            raise ConfigError(f"no zenoh session connecting to {list(connect)} and listening on {list(listen)}: "
                              f"{str(e).split(' at ')[0]}") from None
        self.liveliness = self.session.liveliness()
        self.zid = str(self.session.info.zid())
        self.node_id = 0
        self._next_id = 1
        self._lock = threading.Lock()
        #: Every publisher and subscription, in the order they were made.
        self.endpoints: list[Publisher | Subscription] = []
        self._token = self.liveliness.declare_token(self._node_prefix(self.node_id, "NN"))

    # -- key expressions --------------------------------------------------------------------------------
    def _node_prefix(self, entity_id: int, kind: str) -> str:
        return (f"{ADMIN}/{self.domain}/{self.zid}/{self.node_id}/{entity_id}/{kind}/%/"
                f"{mangle(self.namespace)}/{mangle(self.name)}")

    def keyexprs(self, topic: str, msg_type: str, entity_id: int, kind: str) -> tuple[str, str]:
        """(data key expression, liveliness token) of an endpoint."""
        if not topic.startswith("/") or "//" in topic or topic.endswith("/"):
            raise ValueError(f"topic {topic!r} must be absolute, like /arm/joint_states")
        typ, h = dds_name(msg_type), self.types.hash(msg_type)
        data = f"{self.domain}{topic}/{typ}/{h}"
        token = f"{self._node_prefix(entity_id, kind)}/{mangle(topic)}/{typ}/{h}/{DEFAULT_QOS}"
        return data, token

    def _entity_id(self) -> int:
        with self._lock:
            self._next_id += 1
            return self._next_id - 1

    # -- endpoints --------------------------------------------------------------------------------------
    def publisher(self, topic: str, msg_type: str) -> Publisher:
        pub = Publisher(self, topic, msg_type, self._entity_id())
        self.endpoints.append(pub)
        return pub

    def subscription(self, topic: str, msg_type: str, callback: Callable[[Any], None]) -> Subscription:
        sub = Subscription(self, topic, msg_type, self._entity_id(), callback)
        self.endpoints.append(sub)
        return sub

    def close(self) -> None:
        if self.session is None:
            return
        for e in reversed(self.endpoints):
            try:
                e.close()
            except Exception as exc:  # closing goes on: the session's close withdraws what is left
                log.debug("closing %s: %s", e.topic, exc)
        self.endpoints.clear()
        try:
            self._token.undeclare()
        finally:
            self.session.close()
            self.session = None

    def __enter__(self) -> RosNode:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
