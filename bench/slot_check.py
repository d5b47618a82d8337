"""What the checked slots cost (`python bench/slot_check.py [--json]`).

The ring buffer's writer checksums each slot and its readers check their copy (`rio.runtime.slot_check`), so
shared memory stays correct on CPUs that reorder memory (ARM). This prints, for a small state sample
(7 joints) and a camera sample (640x480 RGB + depth), the cost of one ring-buffer put and one get
(copy), against two references measured in the same run: copying the same bytes with numpy (what
a put or get must do anyway), and the unchecked put/get the buffers did before slot checks (copy
the slot, compare the counter; correct on x86 only). `checksum` alone is listed too. Figures are
medians of `--rounds` rounds.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np

from rio.machine import host
from rio.runtime import slot_check
from rio.runtime.buffers import RingBuffer
from rio.runtime.layout import Layout

CASES = {
    "state (7 joints)": {"q": np.zeros(7), "dq": np.zeros(7), "tau": np.zeros(7), "ee": np.zeros(7)},
    "camera 640x480 rgb+depth": {"rgb": np.zeros((480, 640, 3), np.uint8), "depth": np.zeros((480, 640), np.uint16)},
}


def _per_call_us(fn, n: int) -> float:
    t0 = time.perf_counter()
    for _ in range(n):
        fn()
    return (time.perf_counter() - t0) / n * 1e6


def measure(example: dict, n: int, rounds: int) -> dict[str, float]:
    layout = Layout(example, owner="bench")
    rb = RingBuffer(layout, 8)
    rec = layout.encode({k: v + 1 for k, v in example.items()}, fill_timestamp=0.0)
    src, dst = np.frombuffer(rec.tobytes(), np.uint8).copy(), np.empty(layout.itemsize, np.uint8)
    rb.put_record(rec)
    out: dict[str, list[float]] = {"raw copy": [], "checksum": [], "unchecked put": [], "unchecked get": [],
                                   "put": [], "get": []}
    records, cap = rb._slots.records, rb.capacity

    def unchecked_put() -> None:  # the pre-check writer: slot, then counter
        c = int(rb._count[0])
        records[c % cap] = rec
        rb._count[0] = c + 1

    def unchecked_get() -> np.ndarray:  # the pre-check reader: copy, then re-read the counter
        c = int(rb._count[0])
        r = records[(c - 1) % cap].copy()
        assert int(rb._count[0]) - c < cap - 1
        return r

    for _ in range(rounds):
        out["raw copy"].append(_per_call_us(lambda: np.copyto(dst, src), n))
        out["checksum"].append(_per_call_us(lambda: slot_check.checksum(1, src), n))
        out["unchecked put"].append(_per_call_us(unchecked_put, n))
        out["unchecked get"].append(_per_call_us(unchecked_get, n))
        out["put"].append(_per_call_us(lambda: rb.put_record(rec), n))
        out["get"].append(_per_call_us(rb.get_record, n))
    fig = {k: statistics.median(v) for k, v in out.items()}
    fig["bytes"] = layout.itemsize
    fig["put / raw copy"] = fig["put"] / fig["raw copy"]
    fig["get / raw copy"] = fig["get"] / fig["raw copy"]
    fig["put / unchecked put"] = fig["put"] / fig["unchecked put"]
    fig["get / unchecked get"] = fig["get"] / fig["unchecked get"]
    return fig


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    results = {name: measure(ex, 20000 if "state" in name else 300, args.rounds) for name, ex in CASES.items()}
    if args.json:
        print(json.dumps({"machine": host.describe(), "results": results}))
        return
    print(f"checked ring-buffer slots on {host.describe()} (us per call, median of {args.rounds} rounds)")
    cols = ["raw copy", "checksum", "unchecked put", "unchecked get", "put", "get", "put / raw copy",
            "get / raw copy", "put / unchecked put", "get / unchecked get"]
    for name, f in results.items():
        print(f"{name} ({f['bytes']} bytes):")
        for c in cols:
            print(f"  {c:22s} {f[c]:9.2f}{'' if '/' in c else ' us'}")


if __name__ == "__main__":
    main()
