"""`NetFTBox`: an emulated ATI Net F/T box on 127.0.0.1 (or any loopback address), speaking the real
protocols so the driver runs unchanged against it: RDT over UDP (`rio_ati.rdt`: start realtime or
buffered streaming, stop, a sample count, the software bias) and its configuration page over HTTP
(`netftapi2.xml`: counts per force and torque unit, the units, the RDT rate).

The load it measures is `load` (6 values, N and N m in the sensor frame) plus seeded noise, or what a
`source` callable returns each sample (a sim world's wrist sensor: `rio_ati.sim_source.WristSource`). Like the box,
it samples internally at 7000 Hz (`ft_sequence` counts those samples) and sends at its RDT rate
(`rdt_sequence` counts the records sent since streaming started); the software bias subtracts the
reading at the time of the command from every later one.

    with NetFTBox(load=[0, 0, -9.8, 0, 0, 0]) as box:
        print(box.host, box.rdt_port, box.http_port)      # what the driver's station fields name
"""

from __future__ import annotations

import http.server
import select
import socket
import threading
import time
from collections.abc import Callable, Sequence

import numpy as np

from . import rdt
from .calibration import FORCE_UNITS, PAGE, TORQUE_UNITS

INTERNAL_RATE_HZ = 7000.0


class NetFTBox:
    def __init__(self, load: Sequence[float] = (0.0,) * 6, *, host: str = "127.0.0.1", rdt_port: int = 0,
                 http_port: int = 0, rate_hz: float = 1000.0, counts_per_force: float = 1_000_000.0,
                 counts_per_torque: float = 1_000_000.0, force_unit: str = "N", torque_unit: str = "Nm",
                 noise: float = 0.0, seed: int = 0, buffer_size: int = 40,
                 source: Callable[[], Sequence[float]] | None = None):
        if force_unit not in FORCE_UNITS or torque_unit not in TORQUE_UNITS:
            raise ValueError(f"units {force_unit!r} / {torque_unit!r}: force one of {sorted(FORCE_UNITS)}, "
                             f"torque one of {sorted(TORQUE_UNITS)}")
        self.load = np.asarray(load, dtype=np.float64).reshape(6)
        self.host, self.rate_hz, self.noise, self.buffer_size = host, float(rate_hz), float(noise), int(buffer_size)
        self.cpf, self.cpt = counts_per_force, counts_per_torque
        self.force_unit, self.torque_unit = force_unit, torque_unit
        self.source = source
        #: what the status word of every record carries (set it to emulate a saturated or broken gage)
        self.status = 0
        #: requests received, in order: (command, sample_count)
        self.requests: list[tuple[int, int]] = []
        #: records sent since start
        self.sent = 0
        #: drop every n-th datagram on the way (0: none), as a congested network would
        self.drop_every = 0
        #: records dropped that way
        self.dropped = 0
        self._datagrams = 0
        #: when each record left the box (`rio.clock` seconds), by rdt_sequence modulo its length (benchmarks)
        self.sent_at = np.zeros(1 << 16)
        self.bias_counts = np.zeros(6)
        #: the last load the gages read (N, N m, before noise)
        self.last_load = self.load.copy()
        self._rng = np.random.default_rng(seed)
        self._lock = threading.Lock()
        self._stream: tuple[tuple[str, int], int, int, int] | None = None  # (client, mode, remaining, rdt_seq)
        self._stop = threading.Event()
        self._udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._udp.bind((host, rdt_port))
        self.rdt_port = self._udp.getsockname()[1]
        self._http = http.server.ThreadingHTTPServer((host, http_port), _page_handler(self))
        self._http.daemon_threads = True
        self.http_port = self._http.server_address[1]
        self._t0 = time.monotonic()
        self._threads = [threading.Thread(target=self._serve_rdt, name="netft-rdt", daemon=True),
                         threading.Thread(target=self._http.serve_forever, name="netft-http", daemon=True)]

    # -- life ------------------------------------------------------------------------------------
    def start(self) -> NetFTBox:
        for t in self._threads:
            t.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._http.shutdown()
        for t in self._threads:
            if t.is_alive():
                t.join(timeout=2.0)
        self._http.server_close()
        self._udp.close()

    def __enter__(self) -> NetFTBox:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    @property
    def streaming(self) -> bool:
        return self._stream is not None

    # -- the gage --------------------------------------------------------------------------------
    def raw_counts(self) -> np.ndarray:
        """What the gages read now, in counts of the configured units (before the box's bias)."""
        w = np.asarray(self.source() if self.source is not None else self.load, dtype=np.float64).reshape(6)
        self.last_load = w
        if self.noise:
            w = w + self._rng.normal(0.0, self.noise, 6)
        return np.concatenate([w[:3] / FORCE_UNITS[self.force_unit] * self.cpf,
                               w[3:] / TORQUE_UNITS[self.torque_unit] * self.cpt])

    def ft_sequence(self) -> int:
        return int((time.monotonic() - self._t0) * INTERNAL_RATE_HZ)

    # -- RDT ---------------------------------------------------------------------------------------
    def _serve_rdt(self) -> None:
        next_send = time.monotonic()
        while not self._stop.is_set():
            wait = max(0.0, next_send - time.monotonic()) if self._stream is not None else 0.05
            try:
                readable, _, _ = select.select([self._udp], [], [], wait)
                if readable:
                    data, client = self._udp.recvfrom(64)
                    started = self._handle(data, client)
                    if started:
                        next_send = time.monotonic()
                    continue  # more requests first; then the sends that are due
            except OSError:
                return
            stream, now = self._stream, time.monotonic()
            while stream is not None and now >= next_send:
                stream = self._send(stream)
                next_send += (self.buffer_size if stream and stream[1] == rdt.START_BUFFERED else 1) / self.rate_hz
            if next_send < now - 0.1:  # fell far behind (a loaded machine): no burst, as a box would not
                next_send = now
            if self._stream is not None:  # not stopped by a request meanwhile
                self._stream = stream

    def _handle(self, data: bytes, client: tuple[str, int]) -> bool:
        """Apply one request; True when it started a stream."""
        try:
            command, count = rdt.parse_request(data)
        except ValueError:
            return False  # the box ignores what is not an RDT request
        self.requests.append((command, count))
        if command == rdt.STOP:
            self._stream = None
        elif command in (rdt.START_REALTIME, rdt.START_BUFFERED):
            self._stream = (client, command, count if count else -1, 0)
            return True
        elif command == rdt.SET_SOFTWARE_BIAS:
            with self._lock:
                self.bias_counts = self.raw_counts()
        return False

    def _send(self, stream):
        client, mode, remaining, seq = stream
        n = self.buffer_size if mode == rdt.START_BUFFERED else 1
        if remaining > 0:
            n = min(n, remaining)
        payload = b""
        for _ in range(n):
            with self._lock:
                counts = self.raw_counts() - self.bias_counts
            seq += 1
            payload += rdt.record(seq, self.ft_sequence(), self.status, counts)
            self.sent_at[seq % len(self.sent_at)] = time.monotonic()  # = rio.clock.now()
        self._datagrams += 1
        try:
            if self.drop_every and self._datagrams % self.drop_every == 0:
                self.dropped += n
            else:
                self._udp.sendto(payload, client)
        except OSError:
            return None
        self.sent += n
        if remaining > 0:
            remaining -= n
            if remaining == 0:
                return None
        return (client, mode, remaining, seq)

    # -- the configuration page ----------------------------------------------------------------------
    def page(self) -> str:
        return (f'<?xml version="1.0" encoding="ISO-8859-1"?>\n<netft>\n<prodname>RIO emulated Net F/T</prodname>\n'
                f"<cfgcpf>{self.cpf:g}</cfgcpf>\n<cfgcpt>{self.cpt:g}</cfgcpt>\n"
                f"<scfgfu>{self.force_unit}</scfgfu>\n<scfgtu>{self.torque_unit}</scfgtu>\n"
                f"<comrdtrate>{self.rate_hz:g}</comrdtrate>\n<comrdtbsiz>{self.buffer_size}</comrdtbsiz>\n"
                f"<runstat>{self.status:#010x}</runstat>\n</netft>\n")


def _page_handler(box: NetFTBox) -> type[http.server.BaseHTTPRequestHandler]:
    class Page(http.server.BaseHTTPRequestHandler):
        def do_GET(self) -> None:  # noqa: N802 - the stdlib's name
            if self.path.lstrip("/") != PAGE:
                self.send_error(404)
                return
            body = box.page().encode("latin-1")
            self.send_response(200)
            self.send_header("Content-Type", "text/xml")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, *args) -> None:
            pass

    return Page
