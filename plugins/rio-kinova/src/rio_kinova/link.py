"""What every node of this plugin does the same way: open the shared kortex session (`session.py`),
notice a fault, keep the node alive with the arm held, and recover.

A fault does not end the node: the base stops the arm by itself, the node reports `fault_code` and
`fault`, refuses commands naming the fault, and `clear_faults()` (Base.ClearFaults) brings it back
holding where the arm is. Old goals are never replayed: the node is disabled while in fault.
A lost session (a call without an answer) is held the same core way (`on_lost`, `connected = False`):
the session is reopened once a second, and the node enables again holding where the arm is.
"""

from __future__ import annotations

import logging
from typing import Any

from pydantic import Field, field_validator

from rio.config import Config
from rio.interfaces import Fault, FaultHolding

from . import session as sessions
from .faults import REFUSED_CODE, KinovaError, from_arm_state
from .models import ArmModel

log = logging.getLogger("rio_kinova")


class LinkConfig(Config):
    """Station fields every node on a Kinova base takes (mixed into each driver's Config)."""

    ip: str = Field("192.168.1.10", description="the base's IP address (192.168.1.10 out of the box)")
    username: str = Field("admin", description="kortex session user (a web app account)")
    password: str = Field("admin", description="its password")
    backend: str = Field("kortex", description='"kortex" (a real base), "fake" (stand-in clients with Gen3-like '
                                               'behaviour, no hardware) or "sim" / "sim:ARM@WORLD" (the stand-ins '
                                               'driving a rio-sim world\'s arm)')
    connect_timeout_s: float = Field(5.0, ge=0, description="session inactivity timeouts derive from it (s)")

    @field_validator("ip")
    @classmethod
    def _dotted_ipv4(cls, v: str) -> str:
        import ipaddress

        try:
            return str(ipaddress.IPv4Address(v.strip()))
        except ValueError:
            raise ValueError(f"'{v}' is not an IPv4 address like 192.168.1.10 (the base's)") from None

    @field_validator("backend")
    @classmethod
    def _known_backend(cls, v: str) -> str:
        if v in ("kortex", "fake") or v == "sim" or v.startswith("sim:"):
            return v
        raise ValueError(f"backend '{v}': write 'kortex', 'fake', 'sim' or 'sim:ARM@WORLD'")


class KortexLink(FaultHolding):
    """Mixed in ahead of a commanded kind (`CommandedNode`) whose config is a `LinkConfig`."""

    config: Any
    kinova: ArmModel
    session: sessions.Session | None = None

    def open_session(self) -> sessions.Session:
        c = self.config
        self.session = sessions.acquire(c.backend, c.ip, self.kinova, c.username, c.password, c.connect_timeout_s)
        self.device_label = f"Kinova base at {c.ip}"
        self.fault = None
        return self.session

    def close(self) -> None:
        if self.session is not None:
            sessions.release(self.session)
            self.session = None

    # -- faults (held the core way: rio.interfaces.FaultHolding) ------------------------------------------
    def link_up(self) -> bool:
        return self.session is not None and self.session.alive

    def link_status(self) -> dict[str, Any]:
        """Keys every sample carries; also where a fault the base reported is taken up and a lost session
        reopened."""
        s = self.session
        assert s is not None  # opened
        if not s.alive:
            self.on_lost()
            s.reconnect()
        if s.alive:  # the other node on this base may have reopened the session
            self.on_restored()
        if s.fault is not None and self.fault is None:
            self.on_fault(s.fault)
        return self.fault_status()

    def lose_session(self, e: BaseException) -> None:
        s = self.session
        assert s is not None
        if s.alive:
            log.error("Kinova base at %s: no answer (%s); reconnecting", self.config.ip, e)
            s.alive = False
        self.on_lost()

    def device_fault(self) -> Fault | None:
        """The base's fault now: the notified one, else the arm state asked now (while the session is lost:
        the last one known)."""
        s = self.session
        assert s is not None
        if not s.alive:
            return s.fault or self.fault
        try:
            return s.fault or from_arm_state(s.arm_state())
        except s.lost_errors as e:
            self.lose_session(e)
            return s.fault or self.fault

    def clear_device_faults(self) -> None:
        s = self.session
        assert s is not None
        try:
            s.base.ClearFaults()
        except s.errors as e:
            raise KinovaError(self.config.ip, "ClearFaults", f"{e} (is the emergency stop released?)") from None
        s.fault = None

    def guarded(self, fn, *args: Any) -> Any:
        """Run one kortex call; a refusal turns into the held, named-fault state, no answer into the held,
        reconnecting one."""
        s = self.session
        assert s is not None
        try:
            return fn(*args)
        except s.lost_errors as e:
            self.lose_session(e)
            return None
        except s.errors as e:
            fault = self.device_fault() or Fault(
                REFUSED_CODE, "command_refused", f"the base refused {getattr(fn, '__name__', fn)}: {e}")
            s.fault = s.fault or fault
            self.on_fault(fault)
            return None
