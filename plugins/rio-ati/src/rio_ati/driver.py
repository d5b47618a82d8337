"""`ati.netft`: an ATI Net F/T box (or an Axia80, which speaks the same RDT) as a RIO wrench sensor.

At `open()` the driver reads the box's calibration from its configuration page over HTTP (counts per
force and torque unit, and the units: `rio_ati.calibration`; or the station's `counts_per_force` /
`counts_per_torque` where the page is off), then asks for realtime RDT streaming (`rio_ati.rdt`) and waits
for the first record. Each cycle it drains every datagram that arrived, publishes the newest record in SI
units with the time it arrived, and counts the records lost on the way (gaps in `rdt_sequence`). The box
streams at its own RDT rate (up to 7000 Hz); `rate_hz` is how often the node publishes the newest.

A silent box (unplugged, rebooted) publishes nothing (the wrench's timestamp ages); the driver asks it
to stream again every `restart_s` until it answers. `tare()` sends the box's own "set software bias"
command (`device_tare = true`), so the zero is the box's and every client of the box shares it; the
driver then restarts the stream and publishes nothing measured before the bias.
"""

from __future__ import annotations

import logging
import socket
from typing import Any

import numpy as np
from pydantic import Field

from rio import clock
from rio.errors import RioError
from rio.interfaces import NetworkDevice, WrenchNode

from . import calibration, rdt

log = logging.getLogger("rio_ati")


class NetFTSensor(WrenchNode):
    class Config(NetworkDevice, WrenchNode.Config):
        defaults = {"rate_hz": 1000.0, "frame": "netft"}
        rdt_port: int = Field(rdt.PORT, ge=1, le=65535, description="the box's RDT port (UDP; 49152 on every box)")
        http_port: int = Field(80, ge=1, le=65535, description="the box's web server, which serves netftapi2.xml")
        counts_per_force: float | None = Field(None, gt=0, description="counts per newton, where the box's web "
                                                                        "page is off (default: read from it)")
        counts_per_torque: float | None = Field(None, gt=0, description="counts per newton-meter (likewise)")
        device_tare: bool = Field(True, description="tare() sends the box's 'set software bias' command; false: "
                                                    "the kind's software bias")
        restart_s: float = Field(0.5, gt=0, description="ask a silent box to stream again after this long (s)")

    def setup(self) -> None:
        super().setup()
        self.example_data.update(status=0, rdt_sequence=0, ft_sequence=0, lost=0)
        self.sock: socket.socket | None = None
        self.cal: calibration.Calibration | None = None
        self.last: rdt.Record | None = None
        self.received = self.lost = 0
        self._restarting = False  # after a device tare: records still in flight predate the bias
        self._t_last = self._t_asked = 0.0

    # -- lifecycle ---------------------------------------------------------------------------------
    def open(self) -> None:
        c = self.config
        self.cal = self._calibration()
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
        self.sock.connect((c.ip, c.rdt_port))  # only the box's datagrams reach this socket
        self.sock.setblocking(False)
        self._ask(rdt.START_REALTIME)
        t_end = clock.now() + max(c.connect_timeout_s, 0.1)
        while self._drain() is None:
            if clock.now() > t_end:
                raise RioError(f"node '{self.name}': no RDT record from the Net F/T at {c.ip}:{c.rdt_port} within "
                               f"{c.connect_timeout_s:g} s (is it on this subnet, is RDT enabled on its web page?)")
            if clock.now() - self._t_asked > c.restart_s:
                self._ask(rdt.START_REALTIME)
            clock.precise_wait(clock.now() + 0.005)

    def close(self) -> None:
        if self.sock is not None:
            try:
                self._ask(rdt.STOP)
            except OSError:
                pass
            self.sock.close()
            self.sock = None

    def _calibration(self) -> calibration.Calibration:
        """The station's counts per unit, else the box's page, asked until `connect_timeout_s` has passed
        (a box still booting, or an emulator node starting beside this one, answers after a while)."""
        c = self.config
        if c.counts_per_force is not None and c.counts_per_torque is not None:
            return calibration.Calibration(c.counts_per_force, c.counts_per_torque)
        t_end = clock.now() + c.connect_timeout_s
        while True:
            try:
                return calibration.fetch(c.ip, c.http_port, timeout=max(min(c.connect_timeout_s, 2.0), 0.2))
            except OSError as e:
                if clock.now() + 0.2 < t_end:
                    clock.precise_wait(clock.now() + 0.2)
                    continue
                error: Exception = e
            except ValueError as e:
                error = e
            raise RioError(f"node '{self.name}': cannot read the calibration from http://{c.ip}:{c.http_port}/"
                           f"{calibration.PAGE} ({error}); set counts_per_force and counts_per_torque (the "
                           "calibration sheet's counts per N and N m) if the box's web page is off") from None

    def _ask(self, command: int, count: int = 0) -> None:
        assert self.sock is not None
        self.sock.send(rdt.request(command, count))
        self._t_asked = clock.now()

    # -- the wire ----------------------------------------------------------------------------------
    def _drain(self) -> rdt.Record | None:
        """Every datagram waiting: the newest record, or None when none came; counts losses."""
        assert self.sock is not None
        newest = None
        while True:
            try:
                data = self.sock.recv(65536)
            except (BlockingIOError, InterruptedError):
                break
            except ConnectionRefusedError:  # an ICMP port-unreachable: nothing listens there (yet)
                continue
            try:
                records = rdt.parse_records(data)
            except ValueError as e:
                log.warning("node '%s': dropped a datagram that is not RDT (%s)", self.name, e)
                continue
            for r in records:
                if self._restarting:  # skip until the stream restarted after the bias command (it counts from 1)
                    if r.rdt_sequence != 1 and (self.last is None or r.rdt_sequence > self.last.rdt_sequence):
                        self.last = r
                        continue
                    self._restarting = False
                if self.last is not None:
                    self.lost += rdt.sequence_gap(self.last.rdt_sequence, r.rdt_sequence)
                self.last = newest = r
                self.received += 1
        if newest is not None:
            self._t_last = clock.now()
        return newest

    def read_wrench(self) -> dict[str, Any] | None:
        r = self._drain()
        if r is None:
            now = clock.now()
            if now - self._t_last > self.config.restart_s and now - self._t_asked > self.config.restart_s:
                log.warning("node '%s': the Net F/T at %s sent nothing for %.1f s: asking it to stream again",
                            self.name, self.config.ip, now - self._t_last)
                self._ask(rdt.START_REALTIME)
            return None
        assert self.cal is not None
        force, torque = self.cal.to_si(r.counts)
        return {"force": np.asarray(force), "torque": np.asarray(torque), "timestamp": self._t_last,
                "status": r.status, "rdt_sequence": r.rdt_sequence, "ft_sequence": r.ft_sequence, "lost": self.lost}

    def tare_device(self) -> bool:
        """The box's "set software bias", then a fresh stream: the box numbers a new stream's records from 1,
        so the first record of it is the first one measured after the bias (those still in flight are
        skipped rather than published with the load the tare removed)."""
        if not self.config.device_tare:
            return False
        self._restarting = True
        self._ask(rdt.SET_SOFTWARE_BIAS)
        self._ask(rdt.START_REALTIME)
        return True
