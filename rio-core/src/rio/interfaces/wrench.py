"""The wrench contract: a force/torque sensor (a wrist F/T cell, a sim arm's wrist sensor).

A driver returns the raw wrench from `read_wrench()`: `force` (3, N) and `torque` (3, N m) in the sensor's
own frame (named by the station's `frame`), and optionally `timestamp`, the time the hardware measured it
(`rio.clock` seconds; a packet's arrival, say), and any keys of its own it declared in `example_data`
(a sequence number, a status word). The kind publishes

    force      (3,) N     Fx, Fy, Fz in the sensor frame, minus the bias
    torque     (3,) N m   Tx, Ty, Tz in the sensor frame, minus the bias
    timestamp  s          when it was measured (the driver's, else when it was read)

and owns the tare: `tare()` (a remote call) takes the mean of the last `tare_samples` raw readings as the
bias that every later sample has subtracted, so a tool's weight or a cell's drift reads as zero. A device
that can bias itself (the ATI Net F/T's "set software bias" command) says so from `tare_device()`; the
kind then zeroes its own bias instead, and the readings that follow are the device's. Why in the kind: a
force limit (`rio.control.force_limit`) and a dataset both want the same zero, whichever cell is behind it.
Values the driver does not measure are NaN, never zeros.
"""

from __future__ import annotations

import collections
from collections.abc import Mapping
from typing import Any

import numpy as np
from pydantic import Field

from rio import clock
from rio.runtime.node import Node, NodeConfig, remote

#: The keys of every wrench sample (besides `timestamp`).
WRENCH_KEYS = ("force", "torque")


class WrenchNode(Node):
    client_state = ("frame",)

    class Config(NodeConfig):
        frame: str = Field("ft_sensor", description="name of the sensor frame the wrench is expressed in (for "
                                                    "the record: the cell's, or the sim site's)")
        tare_samples: int = Field(10, ge=1, le=10_000, description="raw readings averaged into the bias by tare()")
        tare_on_open: bool = Field(False, description="tare once at start (the cell unloaded, the tool mounted)")

    # -- driver hooks -------------------------------------------------------------------------------
    def read_wrench(self) -> Mapping[str, Any] | None:
        """This cycle's raw `force` (3, N) and `torque` (3, N m), optionally `timestamp`; None when no new
        reading came (nothing is published)."""
        raise NotImplementedError(f"{type(self).__name__} must define read_wrench()")

    def tare_device(self) -> bool:
        """Bias the device itself, where it can (True); False (the default): the kind tares in software."""
        return False

    # -- contract -----------------------------------------------------------------------------------
    def setup(self) -> None:
        self.frame = self.config.frame
        self.example_data: dict[str, Any] = {"force": np.zeros(3), "torque": np.zeros(3), "timestamp": 0.0}
        self.bias = np.zeros(6)
        self._recent: collections.deque[np.ndarray] = collections.deque(maxlen=self.config.tare_samples)
        self._tare_pending = bool(self.config.tare_on_open)

    def read_state(self) -> dict[str, Any] | None:
        raw = self.read_wrench()
        if raw is None:
            return None
        t = float(raw.get("timestamp", clock.now()))
        w = np.concatenate([vector3(self.name, k, raw.get(k)) for k in WRENCH_KEYS])
        self._recent.append(w)
        if self._tare_pending and len(self._recent) == self._recent.maxlen:
            self._tare_pending = False
            self.tare()
        w = w - self.bias
        out: dict[str, Any] = {"force": w[:3], "torque": w[3:], "timestamp": t}
        out.update((k, v) for k, v in raw.items() if k not in out and k in self.example_data)  # the driver's own keys
        return out

    # -- remote API ---------------------------------------------------------------------------------
    @remote
    def tare(self) -> list[float]:
        """Zero the reading as it is now: the mean of the last `tare_samples` raw readings becomes the bias
        (or the device biases itself, `tare_device()`, and the kind's bias is zero). Returns the bias, 6
        values (N, N m), that later samples have subtracted."""
        if self.tare_device():
            self.bias = np.zeros(6)
            self._recent.clear()
            return self.bias.tolist()
        if not self._recent:
            raise RuntimeError(f"node '{self.name}': nothing read yet to tare against")
        recent = np.array(self._recent)
        self.bias = np.nanmean(recent, axis=0) if np.isfinite(recent).any() else np.zeros(6)
        return self.bias.tolist()

    @remote
    def untare(self) -> None:
        """Drop the kind's bias: raw readings again."""
        self.bias = np.zeros(6)


def vector3(node: str, key: str, value: Any) -> np.ndarray:
    """`value` as 3 floats, or an error naming the node and key; None (not measured) is NaN."""
    if value is None:
        return np.full(3, np.nan)
    v = np.asarray(value, dtype=np.float64).reshape(-1)
    if v.shape != (3,):
        raise ValueError(f"node '{node}': read_wrench() gave '{key}' with {v.size} values, the kind takes 3")
    return v


WrenchConfig = WrenchNode.Config
