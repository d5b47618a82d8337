"""What every node of this plugin does the same way: take the shared kortex session (`session.py`), hold the
faults the base reports and the session's losses (the core's parts, `rio.interfaces.FaultHolder` and
`LinkSupervisor`), and make each call so that a refusal or a missing answer is held, not raised.

A fault does not end the node: the base stops the arm by itself, the node reports `fault_code` and
`fault`, refuses commands naming the fault, and `clear_faults()` (Base.ClearFaults) brings it back
holding where the arm is. Old goals are never replayed: the node is disabled while in fault.
A lost session (a call without an answer) is held the same core way (`connected = False`): the session
is reopened once a second, and the node enables again holding where the arm is.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from pydantic import Field, field_validator

from rio.interfaces import Fault, FaultHolder, LinkSupervisor, NetworkDevice

from . import session as sessions
from .faults import REFUSED_CODE, KinovaError, from_arm_state

log = logging.getLogger("rio_kinova")


class KortexConfig(NetworkDevice):
    """Station fields every node on a Kinova base takes (mixed into each driver's Config)."""

    defaults = {"ip": "192.168.1.10"}  # the base's, out of the box
    username: str = Field("admin", description="kortex session user (a web app account)")
    password: str = Field("admin", description="its password")
    backend: str = Field("kortex", description='"kortex" (a real base), "fake" (stand-in clients with Gen3-like '
                                               'behaviour, no hardware) or "sim" / "sim:ARM@WORLD" (the stand-ins '
                                               'driving a rio-sim world\'s arm)')

    @field_validator("backend")
    @classmethod
    def _known_backend(cls, v: str) -> str:
        if v in ("kortex", "fake") or v == "sim" or v.startswith("sim:"):
            return v
        raise ValueError(f"backend '{v}': write 'kortex', 'fake', 'sim' or 'sim:ARM@WORLD'")


def hold_faults_and_drops(node: Any) -> None:
    """Give `node` (an arm or a gripper on the base at `node.config.ip`, its session `node.session` once open)
    its fault holder and link supervisor."""
    node.session = None
    node.faults = FaultHolder(node, f"Kinova base at {node.config.ip}", ask=lambda: device_fault(node),
                              clear=lambda: clear_device_faults(node))
    node.link = LinkSupervisor(node.faults, up=lambda: node.session is not None and node.session.alive,
                               reconnect=lambda: node.session.reconnect())


def open_session(node: Any) -> sessions.Session:
    c = node.config
    node.session = sessions.acquire(c.backend, c.ip, node.kinova, c.username, c.password, c.connect_timeout_s)
    return node.session


def close_session(node: Any) -> None:
    if node.session is not None:
        sessions.release(node.session)
        node.session = None


def watch(node: Any) -> None:
    """Once per cycle: a lost session is held and reopened, one back brings the node back; a fault the base
    notified is taken up."""
    node.link.watch()
    s = node.session
    if s.fault is not None and node.faults.fault is None:
        node.faults.report(s.fault)


def lose_session(node: Any, e: BaseException) -> None:
    s = node.session
    if s.alive:
        log.error("Kinova base at %s: no answer (%s); reconnecting", node.config.ip, e)
        s.alive = False
    node.link.lost()


def device_fault(node: Any) -> Fault | None:
    """The base's fault now: the notified one, else the arm state asked now (while the session is lost: the
    last one known)."""
    s = node.session
    assert s is not None
    if not s.alive:
        return s.fault or node.faults.fault
    try:
        return s.fault or from_arm_state(s.arm_state())
    except s.lost_errors as e:
        lose_session(node, e)
        return s.fault or node.faults.fault


def clear_device_faults(node: Any) -> None:
    s = node.session
    assert s is not None
    try:
        s.base.ClearFaults()
    except s.errors as e:
        raise KinovaError(node.config.ip, "ClearFaults", f"{e} (is the emergency stop released?)") from None
    s.fault = None


def guarded(node: Any, fn: Callable[..., Any], *args: Any) -> Any:
    """Run one kortex call; a refusal turns into the held, named-fault state, no answer into the held,
    reconnecting one (both return None)."""
    s = node.session
    assert s is not None
    try:
        return fn(*args)
    except s.lost_errors as e:
        lose_session(node, e)
        return None
    except s.errors as e:
        fault = device_fault(node) or Fault(
            REFUSED_CODE, "command_refused", f"the base refused {getattr(fn, '__name__', fn)}: {e}")
        s.fault = s.fault or fault
        node.faults.report(fault)
        return None
