"""A Net F/T's wrench through RIO against the raw UDP stream, in the same run
(`uv run python bench/netft.py [--seconds 3] [--box-hz 1000] [--json]`).

An emulated box (`rio_ati.emulator.NetFTBox`, in this process) streams RDT at `--box-hz`. Two readers,
one after the other, each polling at 1 kHz for `--seconds`:

- raw: a UDP socket in this process asks for the stream and drains it every millisecond (the reference:
  nothing between the wire and the reader);
- rio: the `ati.netft` driver served on the shm middleware (its own process, publishing at 1 kHz), read by a
  client with `get_state()` every millisecond.

For each: the rate the box sent at meanwhile, the rate of distinct records the reader saw (per second; at
most the poll's) and their age when it saw them (from
the box sending the record, by its rdt_sequence, to the reader holding it: p50 / p99, microseconds), and
the ratios rio / raw. The 1 kHz poll alone adds up to 1 ms of age on both sides.
"""

from __future__ import annotations

import argparse
import json
import socket
import uuid

import numpy as np
from rio_ati import rdt
from rio_ati.driver import NetFTSensor
from rio_ati.emulator import NetFTBox

from rio import ServerManager, clock, connect, serve

POLL_S = 0.001


def _stats(seen: dict[int, float], box: NetFTBox, seconds: float, sent: int) -> dict[str, float]:
    ages = np.array([t - box.sent_at[seq % len(box.sent_at)] for seq, t in seen.items()]) * 1e6
    return {"rate_hz": len(seen) / seconds, "age_p50_us": float(np.percentile(ages, 50)),
            "age_p99_us": float(np.percentile(ages, 99)), "box_sent_hz": sent / seconds}


def raw(box: NetFTBox, seconds: float) -> dict[str, float]:
    seen: dict[int, float] = {}
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.connect((box.host, box.rdt_port))
        s.setblocking(False)
        s.send(rdt.request(rdt.START_REALTIME))
        t_end, sent0 = clock.now() + seconds, box.sent
        while clock.now() < t_end:
            newest = None
            while True:
                try:
                    newest = rdt.parse_records(s.recv(65536))[-1]
                except BlockingIOError:
                    break
            if newest is not None:
                seen.setdefault(newest.rdt_sequence, clock.now())
            clock.precise_wait(clock.now() + POLL_S)
        sent = box.sent - sent0
        s.send(rdt.request(rdt.STOP))
    return _stats(seen, box, seconds, sent)


def through_rio(box: NetFTBox, seconds: float) -> dict[str, float]:
    cfg = {"ip": box.host, "rdt_port": box.rdt_port, "http_port": box.http_port, "rate_hz": 1000.0}
    station, seen = f"bench-{uuid.uuid4().hex[:6]}", {}
    with ServerManager("shm", [serve(NetFTSensor, name="ft", **cfg)], station=station), \
            connect(NetFTSensor, "shm", name="ft", station=station, **cfg) as ft:
        clock.precise_wait(clock.now() + 0.5)  # past start-up
        t_end, sent0 = clock.now() + seconds, box.sent
        while clock.now() < t_end:
            seen.setdefault(int(ft.get_state()["rdt_sequence"]), clock.now())
            clock.precise_wait(clock.now() + POLL_S)
        sent = box.sent - sent0
    # the stream restarted with the node: sequence numbers from 1 again, sent_at overwritten by this stream
    return _stats(seen, box, seconds, sent)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--box-hz", type=float, default=1000.0)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    with NetFTBox([0.0, 0.0, -9.8, 0.0, 0.0, 0.0], rate_hz=a.box_hz) as box:
        ref = raw(box, a.seconds)
        rio_ = through_rio(box, a.seconds)
    out = {"box_hz": a.box_hz, "raw": ref, "rio_shm": rio_,
           "ratio": {k: rio_[k] / ref[k] if ref[k] else float("nan") for k in ref}}
    if a.json:
        print(json.dumps(out, indent=2))
        return
    print(f"Net F/T at {a.box_hz:g} Hz, polled at 1 kHz for {a.seconds:g} s each")
    print(f"{'':10s}{'box sent/s':>12s}{'seen/s':>12s}{'age p50 us':>12s}{'age p99 us':>12s}")
    for name, r in (("raw UDP", ref), ("rio shm", rio_)):
        print(f"{name:10s}{r['box_sent_hz']:12.0f}{r['rate_hz']:12.0f}{r['age_p50_us']:12.0f}{r['age_p99_us']:12.0f}")
    q = out["ratio"]
    print(f"{'rio / raw':10s}{q['box_sent_hz']:12.2f}{q['rate_hz']:12.2f}{q['age_p50_us']:12.2f}"
          f"{q['age_p99_us']:12.2f}")


if __name__ == "__main__":
    main()
