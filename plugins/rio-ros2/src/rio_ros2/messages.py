"""ROS 2 message types without a ROS installation and without the network.

Every definition comes from the typestore that `rosbags` ships for each ROS 2 distribution (the
standard `std_msgs`, `sensor_msgs`, `geometry_msgs`, `trajectory_msgs`, `tf2_msgs`, ... as released):
CDR (de)serialization, message classes and the RIHS01 type hash that rmw_zenoh puts in every key
expression all come from it, in-process. Nothing is fetched at run time.

`write_definitions(dir)` writes the same definitions as `.msg` files (`<pkg>/msg/<Type>.msg`), the
layout zenoh-ros2-sdk's message registry reads first, so that library too works offline
(`use_offline_definitions()`; otherwise it clones message repositories from GitHub with git).
"""

from __future__ import annotations

import math
from functools import cache
from pathlib import Path
from typing import Any

#: `--distro` -> rosbags typestore. Humble's rmw_zenoh has no type hashes (see `MessageTypes.hash`).
DISTROS = {"humble": "ROS2_HUMBLE", "jazzy": "ROS2_JAZZY", "kilted": "ROS2_KILTED", "rolling": "LATEST"}
#: What rmw_zenoh on Humble puts where later distributions put the type hash.
NO_TYPE_HASH = "TypeHashNotSupported"


class MessageTypes:
    """The message types of one ROS 2 distribution: classes, CDR, DDS names and type hashes."""

    def __init__(self, distro: str = "jazzy"):
        if distro not in DISTROS:
            raise ValueError(f"unknown ROS 2 distribution {distro!r}; known: {', '.join(DISTROS)}")
        from rosbags.typesys import Stores, get_typestore

        self.distro = distro
        self.store = get_typestore(getattr(Stores, DISTROS[distro]))

    def cls(self, name: str) -> Any:
        """The message class of `pkg/msg/Type` (a dataclass: build it with keyword arguments)."""
        try:
            return self.store.types[name]
        except KeyError:
            raise KeyError(f"{name} is not a standard message of ROS 2 {self.distro}") from None

    def make(self, msg_type: str, /, **fields: Any) -> Any:
        return self.cls(msg_type)(**fields)

    def serialize(self, msg: Any, name: str) -> bytes:
        """CDR, little endian, with its 4-byte encapsulation header (what rmw_zenoh sends)."""
        return bytes(self.store.serialize_cdr(msg, name))

    def deserialize(self, data: bytes, name: str) -> Any:
        return self.store.deserialize_cdr(data, name)

    def hash(self, name: str) -> str:
        """The type hash segment of rmw_zenoh's key expressions (RIHS01, REP 2011)."""
        self.cls(name)
        return NO_TYPE_HASH if self.distro == "humble" else self.store.hash_rihs01(name)

    def time(self, seconds: float) -> Any:
        """`builtin_interfaces/msg/Time` of a wall-clock time (s since the UNIX epoch)."""
        frac, sec = math.modf(max(float(seconds), 0.0))
        return self.make("builtin_interfaces/msg/Time", sec=int(sec), nanosec=min(int(round(frac * 1e9)), 999_999_999))

    def header(self, stamp_s: float, frame_id: str) -> Any:
        return self.make("std_msgs/msg/Header", stamp=self.time(stamp_s), frame_id=frame_id)


def dds_name(name: str) -> str:
    """'sensor_msgs/msg/JointState' -> 'sensor_msgs::msg::dds_::JointState_' (rmw_zenoh's type segment)."""
    pkg, kind, typ = name.split("/")
    return f"{pkg}::{kind}::dds_::{typ}_"


@cache
def message_types(distro: str = "jazzy") -> MessageTypes:
    return MessageTypes(distro)


# -- .msg files for other tools ---------------------------------------------------------------------
def _field_type(node: tuple) -> str:
    from rosbags.typesys.base import Nodetype

    kind, what = node
    if kind == Nodetype.BASE:
        base, bound = what
        return f"{base}<={bound}" if bound else base
    if kind == Nodetype.NAME:
        pkg, _, typ = what.split("/")
        return f"{pkg}/{typ}"
    sub, size = what
    if kind == Nodetype.ARRAY:
        return f"{_field_type(sub)}[{size}]"
    return f"{_field_type(sub)}[<={size}]" if size else f"{_field_type(sub)}[]"


def _constant(name: str, typ: str, value: Any) -> str:
    if isinstance(value, bool):
        value = "true" if value else "false"
    return f"{typ} {name}={value}"


def msg_text(types: MessageTypes, name: str) -> str:
    """The `.msg` definition of `name`, generated from the typestore (fields and constants; no comments)."""
    consts, fields = types.store.fielddefs[name]
    lines = [_constant(*c) for c in consts] + [f"{_field_type(node)} {field}" for field, node in fields]
    return "\n".join(lines) + "\n"


def write_definitions(directory: str | Path, distro: str = "jazzy") -> Path:
    """Write every message of `distro`'s typestore as `<directory>/<pkg>/msg/<Type>.msg`; returns the
    directory. Files already there with the same text are left alone. A directory that cannot be written
    (a file on the way, no permission, /proc) is one ConfigError naming it."""
    from rio.errors import ConfigError

    types = message_types(distro)
    root = Path(directory)
    try:
        for name in types.store.fielddefs:
            pkg, kind, typ = name.split("/")
            path = root / pkg / kind / f"{typ}.msg"
            text = msg_text(types, name)
            if not path.is_file() or path.read_text() != text:
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(text)
    except OSError as e:
        where = f" ({e.filename})" if e.filename else ""
        raise ConfigError(f"{root}: cannot write the message definitions here: {e.strerror or e}{where}") from None
    return root


def use_offline_definitions(directory: str | Path, distro: str = "jazzy") -> Path:
    """Point zenoh-ros2-sdk's message registry at definitions written here (`write_definitions`), so it
    finds every standard message locally and never clones a repository. Call it before creating the
    SDK's publishers or subscribers."""
    from zenoh_ros2_sdk import get_registry

    root = write_definitions(directory, distro)
    get_registry().messages_dir = root
    return root
