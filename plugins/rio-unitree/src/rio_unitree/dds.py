"""DDS for the G1: a participant on one domain and network interface, raw-bytes writers and readers.

Why not the SDK's `ChannelFactoryInitialize`: its factory is a process-wide singleton bound to the
first domain and interface forever, and its channels cannot be closed. A driver must be able to close
and open again, a bridge and a driver share a process in tests, and each test wants its own domain.
So this module makes the same Cyclone DDS domain the SDK makes (its interface configuration, without
the trace file it writes to /tmp) with cyclonedds directly, and the topics use the SDK's own IDL
types, so type names and QoS on the wire are the SDK's. Samples travel as CDR bytes (`rio_unitree.wire`).

A Cyclone domain is per process and per id: participants of one id share it (refcounted here, and
deleted with the last one); a domain the process made elsewhere (e.g. by the SDK's factory) is used as
it is, never deleted.
"""

from __future__ import annotations

import logging
import socket
import threading
import time
from typing import Any

from pydantic import Field

from rio.config import Config

log = logging.getLogger("rio_unitree")


class DdsConfig(Config):
    """Station fields of a node on the robot's DDS topics (the G1, its hands): where its participant joins."""

    interface: str = Field("eth0", description="network interface on the robot's network (192.168.123.x; "
                                               "'lo' for the bridge on this machine)")
    domain_id: int = Field(0, ge=0, le=232, description="DDS domain (the robot's is 0)")

LOWSTATE, LOWCMD, ARM_SDK = "rt/lowstate", "rt/lowcmd", "rt/arm_sdk"
# Unitree's RPC to its motion switcher service (the SDK's `GetClientChannelName("motion_switcher", ...)`)
MOTION_SWITCHER_REQUEST = "rt/api/motion_switcher/request"
MOTION_SWITCHER_RESPONSE = "rt/api/motion_switcher/response"
# Unitree's Inspire hand service on the G1 (its DFX_inspire_service, namespace "inspire"): both hands
INSPIRE_CMD, INSPIRE_STATE = "rt/inspire/cmd", "rt/inspire/state"
_PRECONDITION_NOT_MET = -4

_CONFIG = """<?xml version="1.0" encoding="UTF-8" ?>
<CycloneDDS><Domain Id="any"><General><Interfaces>
  <NetworkInterface name="{interface}" priority="default" multicast="default"/>
</Interfaces></General></Domain></CycloneDDS>"""

_lock = threading.Lock()
_domains: dict[int, list[Any]] = {}  # id -> [Domain or None (not ours), users, interface]


def udp_ports(domain_id: int) -> range:
    """The UDP ports Cyclone DDS binds for `domain_id` (its default mapping: 7400 + 250 * domain, 250 of them):
    a socket already on one of them stops the domain from starting."""
    base = 7400 + 250 * int(domain_id)
    return range(base, base + 250)


def interfaces() -> list[str]:
    return [name for _, name in socket.if_nameindex()]


def _types() -> dict[str, Any]:
    from unitree_sdk2py.idl.unitree_api.msg.dds_ import Request_, Response_
    from unitree_sdk2py.idl.unitree_go.msg.dds_ import MotorCmds_, MotorStates_
    from unitree_sdk2py.idl.unitree_hg.msg.dds_ import HandCmd_, HandState_, LowCmd_, LowState_

    out = {LOWSTATE: LowState_, LOWCMD: LowCmd_, ARM_SDK: LowCmd_}
    for side in ("left", "right"):
        out[f"rt/dex3/{side}/cmd"], out[f"rt/dex3/{side}/state"] = HandCmd_, HandState_
    out[INSPIRE_CMD], out[INSPIRE_STATE] = MotorCmds_, MotorStates_  # both Inspire hands, 12 motors
    out[MOTION_SWITCHER_REQUEST], out[MOTION_SWITCHER_RESPONSE] = Request_, Response_
    return out


def _delete(entity: Any) -> None:
    """Delete a cyclonedds entity now (what its finalizer does; idempotent), rather than when the
    garbage collector gets to it: its threads and sockets go with it."""
    if entity is not None:
        entity.__del__()


class Participant:
    """One DDS participant in `domain_id` on `interface` (e.g. "eth0", "lo"). Close it (or use `with`)."""

    def __init__(self, domain_id: int, interface: str):
        from cyclonedds.core import DDSException
        from cyclonedds.domain import Domain, DomainParticipant

        self.domain_id, self.interface = int(domain_id), interface
        self._entities: list[Any] = []
        with _lock:
            entry = _domains.get(self.domain_id)
            if entry is None:
                if interface not in interfaces():
                    raise ValueError(f"no network interface '{interface}' on this machine (it has "
                                     f"{', '.join(interfaces())}): set `interface` to the one on the robot's "
                                     "network (192.168.123.x)")
                try:
                    domain = Domain(self.domain_id, _CONFIG.format(interface=interface))
                except DDSException as e:
                    if e.code != _PRECONDITION_NOT_MET:
                        ports = udp_ports(self.domain_id)
                        raise ValueError(f"DDS could not start on interface '{interface}' (domain {domain_id}): "
                                         f"{e}; it binds UDP ports {ports[0]}-{ports[-1]}, and a socket already "
                                         "on one of them stops it (Cyclone's own message above names the "
                                         "port)") from None
                    domain = None  # made elsewhere in this process (the SDK's factory): use it as it is
                    log.info("DDS domain %d exists already in this process; its interface setting applies",
                             domain_id)
                entry = _domains[self.domain_id] = [domain, 0, interface]
            elif entry[2] != interface:
                raise ValueError(f"DDS domain {domain_id} is open on interface '{entry[2]}' in this process; "
                                 f"one process uses one interface per domain (asked for '{interface}')")
            entry[1] += 1
        try:
            self.participant = DomainParticipant(self.domain_id)
        except Exception:
            self._release_domain()
            raise
        self._topics: dict[str, Any] = {}
        self.closed = False

    def _topic(self, name: str) -> Any:
        from cyclonedds.topic import Topic

        if name not in self._topics:
            with _lock:  # two nodes of one process (thread middleware) creating the same topic at once: seen
                # failing in cyclonedds ("Non specific error" upon a Topic's initialisation) on a loaded machine
                self._topics[name] = Topic(self.participant, name, _types()[name])
            self._entities.append(self._topics[name])
        return self._topics[name]

    def writer(self, name: str) -> Writer:
        from cyclonedds.pub import DataWriter

        topic = self._topic(name)
        with _lock:
            w = DataWriter(self.participant, topic)
        self._entities.append(w)
        return Writer(w, name)

    def reader(self, name: str, depth: int = 1) -> Reader:
        """A reader keeping the newest `depth` samples (1: only the latest matters)."""
        from cyclonedds.qos import Policy, Qos
        from cyclonedds.sub import DataReader

        topic = self._topic(name)
        with _lock:
            r = DataReader(self.participant, topic, Qos(Policy.History.KeepLast(depth)))
        self._entities.append(r)
        return Reader(r, name, depth)

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        for e in reversed(self._entities):
            _delete(e)
        self._entities.clear()
        self._topics.clear()
        _delete(self.participant)
        self._release_domain()

    def _release_domain(self) -> None:
        with _lock:
            entry = _domains.get(self.domain_id)
            if entry is None:
                return
            entry[1] -= 1
            if entry[1] <= 0:
                del _domains[self.domain_id]
                _delete(entry[0])

    def __enter__(self) -> Participant:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class Writer:
    def __init__(self, writer: Any, topic: str):
        from cyclonedds._clayer import ddspy_write

        self._write, self._writer, self.topic = ddspy_write, writer, topic
        self.sent = 0

    def matched(self) -> int:
        """How many readers of this topic it has found."""
        return len(self._writer.get_matched_subscriptions())

    def wait_matched(self, timeout_s: float) -> bool:
        """Wait (at most `timeout_s`) for discovery to pair it with a reader: samples written before
        that are lost (the SDK's own writers sleep 0.2 s after creation for the same reason)."""
        t_end = time.monotonic() + timeout_s
        while self.matched() == 0:
            if time.monotonic() > t_end:
                return False
            time.sleep(0.005)
        return True

    def write(self, data: bytes) -> None:
        """Send one serialized sample (header included)."""
        ret = self._write(self._writer._ref, data)
        if ret < 0:
            raise OSError(f"DDS write on {self.topic} failed (return code {ret})")
        self.sent += 1


class Reader:
    def __init__(self, reader: Any, topic: str, depth: int):
        from cyclonedds._clayer import ddspy_take
        from cyclonedds.core import InstanceState, SampleState, ViewState

        self._take, self._reader, self.topic, self.depth = ddspy_take, reader, topic, depth
        self._mask = SampleState.Any | ViewState.Any | InstanceState.Any

    def take(self) -> list[bytes]:
        """The samples received since the last call, oldest first (at most `depth`); never blocks."""
        ret = self._take(self._reader._ref, self._mask, self.depth)
        if isinstance(ret, int):
            raise OSError(f"DDS take on {self.topic} failed (return code {ret})")
        return [data for data, info in ret if info.valid_data]

    def latest(self) -> bytes | None:
        got = self.take()
        return got[-1] if got else None
