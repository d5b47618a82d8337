"""An arm's force limit, as the station sets it (`[components.arm.force_limit]`), and the part of the arm
kind that feeds it: the driver's wrench source, zeroed when the arm is enabled.

The wrench source is the driver's `read_wrench()`: the external force (N) and torque (N m) at the tool that
its hardware measures or estimates (a wrist force/torque cell it reads, a controller's estimated external
force, a sim arm's wrist sensor); or, where the station names one (`wrench_source`), a separate wrench node's
samples (`rio.interfaces.wrench_peer`), whose silence or death holds the arm too. The zero is the reading
when the arm is enabled (`tare_on_enable`; with a separate node, also when it is handed over to an enabled
arm), while it holds still and touches nothing, so a tool's weight does not count. The limit itself, and the hold, are
the commander's (`rio.control.commander._Commander.guard`), so there is one place where a wrench stops an arm.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field, model_validator

from rio import clock
from rio.config import Config
from rio.control.force_limit import ForceLimit
from rio.interfaces.wrench_peer import PeerWrench


class ForceLimitConfig(Config):
    force_n: float | None = Field(None, gt=0, description="hold when the external force's magnitude exceeds "
                                                          "this (N)")
    torque_nm: float | None = Field(None, gt=0, description="hold when the external torque's magnitude exceeds "
                                                            "this (N m)")
    tare_on_enable: bool = Field(True, description="zero the wrench when the arm is enabled (holding still, "
                                                   "touching nothing): the tool's weight does not count")
    source_timeout_s: float = Field(0.2, gt=0, le=10, description="with a separate wrench node as the source "
                                    "(the arm's wrench_source): hold the arm when no new sample has reached it for "
                                    "this long (s)")

    @model_validator(mode="after")
    def _a_limit(self) -> ForceLimitConfig:
        if self.force_n is None and self.torque_nm is None:
            raise ValueError("set force_n, torque_nm or both")
        return self

    def limit(self) -> ForceLimit:
        return ForceLimit(self.force_n, self.torque_nm)


class WrenchSource:
    """The arm's wrench as the force limit sees it: the driver's reading (or, with `peer`, a separate wrench
    node's) minus the zero taken at enable; `fault` says why this cycle's cannot be trusted (the peer's
    silence or death), or is None."""

    def __init__(self, node: Any, config: ForceLimitConfig, peer: PeerWrench | None = None):
        self.node, self.config, self.peer = node, config, peer
        self.bias = np.zeros(6)
        #: the last wrench checked (N, N m); NaN before the first reading
        self.last = np.full(6, np.nan)
        self.fault: str | None = None

    @property
    def starting(self) -> bool:
        """The source is a separate node not handed over yet (the station is starting): a hold, but no alarm."""
        return self.peer is not None and not self.peer.ever_connected

    def _raw(self) -> Any:
        if self.peer is None:
            self.fault = None
            return self.node.read_wrench()
        w, self.fault = self.peer.read(clock.now())
        return w

    def read(self) -> np.ndarray:
        w = self._raw()
        if w is None:
            self.last = np.full(6, np.nan)
        else:
            w = np.asarray(w, dtype=np.float64).reshape(-1)
            if w.shape != (6,):
                raise ValueError(f"node '{self.node.name}': read_wrench() gave {w.size} values; the force limit "
                                 "takes 6 (force N, torque N m)")
            self.last = w - self.bias
        return self.last

    def tare(self) -> None:
        if self.config.tare_on_enable:
            w = self._raw()
            self.bias = np.zeros(6) if w is None else np.nan_to_num(np.asarray(w, dtype=np.float64).reshape(6))
