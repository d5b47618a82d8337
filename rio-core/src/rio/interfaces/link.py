"""A connection that can drop: `LinkSupervisor`, the part of a commanded node that watches it.

A cable pulled or a controller rebooting is, like a fault (`rio.interfaces.faults`), a way a device stops
answering without the node ending: the node holds, disabled, says `connected = False` in its samples,
refuses commands naming the device, and retries the connection; when the link is back it enables again
holding where the device is now (if it was enabled when the link dropped), or holds the fault the device
reports then. A driver with such a link gives its node a supervisor next to its fault holder:

    self.faults = FaultHolder(self, f"UR at {ip}", ask=..., clear=...)
    self.link = LinkSupervisor(self.faults, up=lambda: conn.connected, reconnect=conn.reconnect)

and calls `self.link.watch()` once per cycle from its read (`reconnect` paces itself: once a second is
plenty), and `self.link.lost()` where a call gets no answer. Nodes sharing one connection (an arm and its
gripper) each watch it, so whichever reconnects, both come back.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from rio.errors import InvalidRequest
from rio.interfaces.faults import FaultHolder

log = logging.getLogger("rio.interfaces")


class LinkSupervisor:
    """`up()`: whether the link is usable now; `reconnect()`: one paced attempt to bring it back."""

    def __init__(self, faults: FaultHolder, *, up: Callable[[], bool], reconnect: Callable[[], Any] | None = None):
        self.faults = faults
        self._up, self._reconnect = up, reconnect
        self._enable_when_restored = False

    def up(self) -> bool:
        return bool(self._up())

    def watch(self) -> bool:
        """Once per cycle: a link found down is held (`lost()`) and retried, a link found up brings the
        node back (`restored()`). Returns whether it is up."""
        if not self.up():
            self.lost()
            if self._reconnect is not None:
                self._reconnect()
        if self.up():
            self.restored()
            return True
        return False

    def lost(self) -> None:
        """The link dropped (retried from `watch()`): hold, disabled, until it is restored."""
        node = self.faults.node
        if node.enabled:
            log.error("node '%s': lost %s; holding, reconnecting", node.name, self.faults.device)
            node.enabled = False
            self._enable_when_restored = True

    def restored(self) -> None:
        """The link is up (said every cycle it is: nodes sharing one connection see it come back at different
        times). After a drop: enable again, holding where the device is now, if the node was enabled when it
        dropped; a fault the device reports now is held instead, for `clear_faults()`."""
        if not self._enable_when_restored:
            return
        self._enable_when_restored = False
        node = self.faults.node
        fault = self.faults.ask()
        if fault is not None:
            self.faults.report(fault)
            return
        log.warning("node '%s': %s is back; holding where it is", node.name, self.faults.device)
        try:
            node.enable()
        except InvalidRequest as e:
            # the link dropped again (or a fault appeared) between the driver's check and enabling: this is
            # a sample read, never a request, so it holds and says so; a dropped link re-enables next time
            self._enable_when_restored = not self.up()
            log.warning("node '%s': not enabled again yet: %s", node.name, e.problem)

    def check(self) -> None:
        """Raise `InvalidRequest` naming the device while the link is down."""
        if not self.up():
            raise InvalidRequest(self.faults.node.name, None, f"the link to {self.faults.device} is down "
                                 "(reconnecting); nothing was sent")
