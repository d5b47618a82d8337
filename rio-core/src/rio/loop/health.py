"""What the control loop watches in the robot's nodes every tick, so a run's end says what went wrong with them.

A commanded node that stops obeying does not end the run by itself: a device that reports a fault is held,
disabled (`rio.interfaces.faults`); a link that drops is held and retried (`rio.interfaces.link`); an
emergency stop or a watchdog disables it. Its samples say so (`fault_code`, `connected`, `enabled`), and
the commands the loop sends meanwhile are refused in the node, out of the loop's sight. Without this watch
such a run ended "duration reached" with exit status 0, the fault visible only in log lines above the summary.

`NodeHealth` compares each robot node's newest sample with the one before (the samples the embodiment read
for this tick's observation, so it costs three dict lookups per node) and records, once per node and kind,
when a fault appeared, the link dropped, or the node was disabled without a fault or a lost link to explain it
(a safety stop). At the end it asks each faulted node what its fault is (`fault_info()`, a remote call, once).
A node that was disabled before the run started (`enable_on_open = false`) is not a safety stop.
"""

from __future__ import annotations

import logging
from typing import Any

from rio.errors import RioError
from rio.loop.summary import DISABLED, FAULT, LINK, RunSummary

log = logging.getLogger("rio.loop")


class NodeHealth:
    """Watches `clients` ({role: connected client}) for `summary`. `samples`: {role: the newest sample} kept
    up to date by someone who reads them anyway (an embodiment's `samples`); a role missing there is read."""

    def __init__(self, clients: dict[str, Any], summary: RunSummary, samples: dict[str, Any] | None = None):
        self.clients, self.summary = dict(clients), summary
        self.samples = samples if samples is not None else {}
        self._last: dict[str, tuple[bool | None, int, bool | None]] = {}
        self._faulted: dict[str, int] = {}  # role -> the fault code first seen
        for role, client in self.clients.items():
            self._last[role] = _status(client.get_state())

    def check(self, t_s: float | None) -> None:
        """Look at each node's newest sample (`t_s`: seconds into the run, for the events)."""
        for role, client in self.clients.items():
            sample = self.samples.get(role)
            self._see(role, _status(sample if sample is not None else client.get_state()), t_s)

    def _see(self, role: str, now: tuple[bool | None, int, bool | None], t_s: float | None) -> None:
        enabled, fault, connected = now
        was_enabled, was_fault, was_connected = self._last[role]
        self._last[role] = now
        if fault and fault != was_fault:
            self._faulted.setdefault(role, fault)
            self.summary.add_event(FAULT, role, f"its device reported fault code {fault}; it holds, disabled, "
                                                "until clear_faults()", t_s)
        elif connected is False and was_connected is not False:
            self.summary.add_event(LINK, role, "lost the link to its device; it holds, disabled, and reconnects", t_s)
        elif was_enabled is True and enabled is False and not fault and connected is not False:
            self.summary.add_event(DISABLED, role, "disabled during the run without the workflow asking (an "
                                                   "emergency stop, a watchdog, another client's disable()): it "
                                                   "took no command from then on", t_s)

    def finish(self) -> None:
        """A last look (what happened while the arms settled counts too), then each fault's own words."""
        for role, client in self.clients.items():
            try:
                self._see(role, _status(client.get_state()), None)
            except RioError:  # a node that died: its error is an event of its own
                continue
        for event in self.summary.events:
            if event.kind != FAULT or event.node not in self._faulted:
                continue
            client = self.clients[event.node]
            if "fault_info" not in dir(client):
                continue
            try:
                info = client.fault_info()
            except Exception as e:  # its words are a courtesy: the code is reported already
                log.debug("node '%s': fault_info() failed: %s", event.node, e)
                continue
            if info:
                tag = f"{info.get('tag')} " if info.get("tag") else ""
                recovery = f"; {info['recovery']}" if info.get("recovery") else ""
                event.message = f"{tag}{info.get('name', 'fault')} (code {self._faulted[event.node]}): " \
                                f"{info.get('meaning', '')}{recovery}"


def _status(sample: Any) -> tuple[bool | None, int, bool | None]:
    """(enabled, fault_code, connected) of a sample (numpy scalars made plain); None for what the node does
    not report, fault code 0 when it reports none."""
    enabled, fault, connected = sample.get("enabled"), sample.get("fault_code"), sample.get("connected")
    return (None if enabled is None else bool(enabled), 0 if fault is None else int(fault),
            None if connected is None else bool(connected))
