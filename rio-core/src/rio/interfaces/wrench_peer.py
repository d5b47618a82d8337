"""A separate wrench node as an arm's wrench source: the arm's own client of the station's force/torque sensor
node (`wrench_source = "ft_sensor"` in the arm's station table), read every arm cycle.

The arm's process cannot know where the sensor node is when it starts (no node's address exists before all
are ready), so the station's `Env` hands it a client reference once both are up
(`ArmNode.use_wrench_source(ft.reference)`, `rio.runtime.peer`): the arm connects with `rio.connect`, on the
station's middleware, from wherever it runs (a thread, its own process under shm, another machine over
zmq/zenoh). Reads are the latest sample in the arm's local copy of the sensor's ring buffer: nothing waits.

A force limit whose source is silent is no safety, so each of these holds the arm as a crossing does
(`_Commander.guard`'s `fault`), logged by node name and counted in `force_holds`:

- no reference handed yet (the arm was started without the station's `Env`: see `use_wrench_source`);
- no new sample for `source_timeout_s`, timed on the arm's own clock from when a sample with a new
  `timestamp` first reached it (so a sensor on another machine, whose clock is not the arm's, is judged
  the same way; what it measures is the sensor's silence plus the transport's delay);
- the sensor node died (its client says so by name): held until a new reference is handed.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from rio.errors import InvalidRequest, NodeDiedError, RioError

log = logging.getLogger("rio.interfaces")


class PeerWrench:
    """The wrench of station node `source`, read through a client the arm's process holds."""

    def __init__(self, node: Any, source: str, timeout_s: float):
        self.node, self.source, self.timeout_s = node, source, float(timeout_s)
        self.client: Any = None
        self._stamp: float | None = None  # the newest sample's own timestamp
        self._seen = 0.0  # when (the arm's clock) a sample with a new timestamp last arrived, or we connected
        self._gone: str | None = None  # why the source is gone for good (until a new reference)
        #: a reference was handed over once (before that, the hold is the station starting up)
        self.ever_connected = False

    def connect(self, reference: dict[str, Any], now: float) -> None:
        """Connect (again) from `reference` (`rio.runtime.peer`), which must name `source`."""
        named = reference.get("node") if isinstance(reference, dict) else None
        if named != self.source:
            raise InvalidRequest(self.node.name, "wrench_source", f"handed a reference to node '{named}', but the "
                                                                  f"station names '{self.source}'")
        from rio.interfaces.wrench import WrenchNode
        from rio.plugins.specs import import_path
        from rio.runtime.peer import connect_reference

        try:
            cls = import_path(str(reference.get("class", "")))
        except (ImportError, AttributeError, ValueError) as e:
            raise InvalidRequest(self.node.name, "wrench_source", f"node '{named}''s class cannot be imported here: "
                                                                  f"{type(e).__name__}: {e}") from e
        if not (isinstance(cls, type) and issubclass(cls, WrenchNode)):
            what = getattr(cls, "__name__", cls)
            raise InvalidRequest(self.node.name, "wrench_source", f"node '{named}' is a {what}, not a wrench sensor "
                                                                  "(rio.interfaces.WrenchNode)")
        client = connect_reference(reference)
        self.close()
        self.client, self._stamp, self._seen, self._gone = client, None, now, None
        self.ever_connected = True
        log.info("node '%s': force limit reads wrench source '%s' (a hold after %.3g s without a new sample)",
                 self.node.name, self.source, self.timeout_s)

    def read(self, now: float) -> tuple[np.ndarray | None, str | None]:
        """(the source's newest wrench, 6 values, or None; why it cannot be trusted now, or None)."""
        src = f"its wrench source '{self.source}'"
        if self.client is None:
            return None, f"{src} is not connected (the station's Env hands it over once every node is up)"
        if self._gone is not None:
            return None, self._gone
        try:
            sample = self.client.get_state()
        except NodeDiedError as e:
            self._gone = f"{src} stopped ({e})"
            return None, self._gone
        except RioError:  # it has published nothing yet: silent, judged by the timeout below
            sample = None
        if sample is not None and sample["timestamp"] != self._stamp:
            self._stamp, self._seen = float(sample["timestamp"]), now
        age = now - self._seen
        if age > self.timeout_s:
            return None, f"{src} is silent: no new sample for {age:.2f} s (source_timeout_s = {self.timeout_s:g} s)"
        if sample is None:
            return None, None
        return np.concatenate([np.asarray(sample["force"], np.float64), np.asarray(sample["torque"], np.float64)]), None

    def close(self) -> None:
        if self.client is not None:
            try:
                self.client.close()
            except Exception as e:  # closing a client of a dead node: nothing left to release
                log.debug("node '%s': closing the client of '%s': %s", self.node.name, self.source, e)
            self.client = None
