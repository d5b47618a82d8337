"""What every node of this plugin does the same way: open the shared controller connection, notice a
fault or a dropped socket, keep the node alive with the device held, and recover.

A fault does not end the node (unlike a servo bus error on a hobby arm): the xArm stops and brakes by
itself, the node reports `fault_code` and refuses commands naming the fault, and `clear_faults()` (or
`rio ufactory clear-errors` from a shell, while the station runs) brings it back holding where it is.
A dropped command socket is retried once a second; meanwhile `connected` is false and commands are
refused, and after the reconnect the node holds where the arm is, whatever was commanded before.
"""

from __future__ import annotations

import logging
from typing import Any

from pydantic import Field, field_validator

from rio.config import Config
from rio.interfaces import Fault, FaultHolding

from .controller import Controller
from .faults import XArmFault, XArmLost

log = logging.getLogger("rio_ufactory")


class LinkConfig(Config):
    """Station fields every node on an xArm controller takes (mixed into each driver's Config)."""

    ip: str = Field(description="controller IP address (on the control box's label; `rio ufactory emulator` "
                                "prints its own)")
    connect_timeout_s: float = Field(5.0, ge=0, description="keep trying to connect this long at start (s): a "
                                                            "controller still booting answers after a while")

    @field_validator("ip")
    @classmethod
    def _dotted_ipv4(cls, v: str) -> str:
        import ipaddress

        try:  # the SDK takes anything else for a serial port
            return str(ipaddress.IPv4Address(v.strip()))
        except ValueError:
            raise ValueError(f"'{v}' is not an IPv4 address like 192.168.1.185 (the controller's, on its "
                             "label)") from None


class ControllerLink(FaultHolding):
    """Mixed in ahead of a commanded kind (`CommandedNode`) whose config is a `LinkConfig`. Faults are held
    the core way (`rio.interfaces.FaultHolding`); this adds the controller connection and its drops."""

    config: Any
    ctl: Controller | None = None
    model_name: str | None = None  # checked against the controller's identity when set

    def open_controller(self) -> Controller:
        c = self.config
        self.ctl = Controller.acquire(c.ip, model=self.model_name, connect_timeout_s=c.connect_timeout_s)
        self.device_label = f"xArm at {c.ip}"
        self.fault = None
        return self.ctl

    def close(self) -> None:
        if self.ctl is not None:
            self.ctl.release()
            self.ctl = None

    # -- FaultHolding hooks -----------------------------------------------------------------------------
    def device_fault(self) -> Fault | None:
        assert self.ctl is not None
        return self.ctl.fault()

    def clear_device_faults(self) -> None:
        assert self.ctl is not None
        self.ctl.clear_faults()

    # -- connection (a drop is held the core way too: on_lost / on_restored) --------------------------------
    def link_up(self) -> bool:
        return self.ctl is not None and self.ctl.connected

    def link_status(self) -> dict[str, Any]:
        """Keys every sample carries; also where a dropped socket is noticed and retried."""
        ctl = self.ctl
        assert ctl is not None  # opened
        if not ctl.connected:
            self.on_lost()
            ctl.reconnect()
        if ctl.connected:  # the other node on this controller may have reconnected it
            self.on_restored()
        return self.fault_status()

    def guarded(self, fn, *args: Any) -> None:
        """Run one device command; a controller fault turns into the held, named-fault state, a lost link
        into the held, reconnecting one."""
        try:
            fn(*args)
        except XArmFault as e:
            self.on_fault(e.fault)
        except XArmLost:
            self.on_lost()
