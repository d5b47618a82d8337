"""Reordering stress test of the shared-memory protocols: many processes, checksummed payloads.

Run it where memory order matters (a Jetson, a Raspberry Pi, an Apple-silicon Mac):

    python -m rio.conformance.ordering --samples 10000000

Ring buffers (one writer each, several readers) and a request queue (several producers under the
real cross-process lock, one consumer) live in one shared file mapped by every process. Each
sample's payload is a function of its writer and sequence number, so a reader checks every sample
it accepts *independently of the slot checks the buffers use*:

- torn: the payload does not match its sequence number (a mix of two writes, or bytes not yet visible);
- stale: a ring read returned a sample older than the count the reader had already seen;
- lost / duplicated / reordered: a queue consumer did not get each producer's samples exactly once,
  in order.

`unchecked=True` reads the rings bypassing the slot checks (copy the slot the count points at, as the
pre-check code did): on any machine that run must report torn reads, which shows the checks can see
them. A pass on one machine is evidence, not proof: the protocol's argument is in `rio.runtime.slot_check`.
"""

from __future__ import annotations

import argparse
import json
import mmap
import multiprocessing as mp
import os
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from rio.machine import host
from rio.runtime.buffers import RequestQueue, RingBuffer
from rio.runtime.layout import Layout

_MULT = np.uint64(2654435761)


def _layout(payload: int) -> Layout:
    return Layout({"seq": np.int64(0), "src": np.int64(0), "data": np.zeros(payload, np.uint32)},
                  owner="stress", add_timestamp=False)


def _pattern(src: int, seq: int, payload: int) -> np.ndarray:
    base = np.arange(payload, dtype=np.uint64) * _MULT + np.uint64(seq * 40503 + src * 977)
    return (base & np.uint64(0xFFFFFFFF)).astype(np.uint32)


@dataclass
class Plan:
    samples: int = 1_000_000
    rings: int = 2
    readers: int = 2
    producers: int = 3
    payload: int = 256
    ring_capacity: int = 4
    queue_capacity: int = 16
    unchecked: bool = False
    timeout_s: float = 300.0

    def per_writer(self) -> int:
        return max(1, self.samples // (self.rings + self.producers))


@dataclass
class Report:
    plan: dict[str, Any]
    machine: str = field(default_factory=lambda: host.describe())
    written: int = 0
    reads: int = 0
    torn: int = 0
    stale: int = 0
    queue_received: int = 0
    queue_errors: int = 0
    seconds: float = 0.0
    problems: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not (self.torn or self.stale or self.queue_errors or self.problems)


def _areas(plan: Plan) -> tuple[list[int], int, int]:
    layout = _layout(plan.payload)
    ring_size = RingBuffer.nbytes(layout, plan.ring_capacity)
    offsets = [i * ring_size for i in range(plan.rings)]
    queue_at = plan.rings * ring_size
    return offsets, queue_at, queue_at + RequestQueue.nbytes(layout, plan.queue_capacity)


def _open(path: str, size: int) -> tuple[int, mmap.mmap]:
    fd = os.open(path, os.O_RDWR)
    return fd, mmap.mmap(fd, size)


def _ring(plan: Plan, mm: mmap.mmap, k: int) -> RingBuffer:
    offsets, _, _ = _areas(plan)
    layout = _layout(plan.payload)
    size = RingBuffer.nbytes(layout, plan.ring_capacity)
    return RingBuffer(layout, plan.ring_capacity, buf=memoryview(mm)[offsets[k]:offsets[k] + size])


def _queue(plan: Plan, mm: mmap.mmap, fd: int) -> RequestQueue:
    _, at, end = _areas(plan)
    return RequestQueue(_layout(plan.payload), plan.queue_capacity, buf=memoryview(mm)[at:end],
                        lock=host.FileLock(fd), put_timeout=plan.timeout_s)


def _writer(path: str, plan: Plan, src: int, out: Any) -> None:
    """Writer `src`: of ring `src` when src < plan.rings, else a producer into the queue."""
    fd, mm = _open(path, _areas(plan)[2])
    target: RingBuffer | RequestQueue = _ring(plan, mm, src) if src < plan.rings else _queue(plan, mm, fd)
    rec = target.layout.empty()
    for seq in range(plan.per_writer()):
        rec["seq"], rec["src"], rec["data"] = seq, src, _pattern(src, seq, plan.payload)
        target.put_record(rec)
    out.put(("written", plan.per_writer()))


def _slow_copy(ring: RingBuffer, slot: int) -> np.ndarray:
    """The unchecked read of a reader preempted half-way through its copy (what a loaded machine does
    to any reader now and then), so the negative control sees the race every run, not by luck."""
    raw, half = ring._slots.raw[slot], ring.layout.itemsize // 2
    out = np.empty(ring.layout.itemsize, np.uint8)
    out[:half] = raw[:half]
    time.sleep(0.0005)
    out[half:] = raw[half:]
    return out.view(ring.layout.dtype)[0]


def _ring_reader(path: str, plan: Plan, out: Any) -> None:
    fd, mm = _open(path, _areas(plan)[2])
    rings = [_ring(plan, mm, k) for k in range(plan.rings)]
    last = plan.per_writer() - 1
    newest = [-1] * plan.rings
    reads = torn = stale = 0
    deadline = time.monotonic() + plan.timeout_s
    while min(newest) < last and time.monotonic() < deadline:
        for k, ring in enumerate(rings):
            seen = ring.count
            if seen == 0:
                continue
            if plan.unchecked:  # what the buffers did before slot checks: trust the count, copy the slot
                rec = _slow_copy(ring, (seen - 1) % ring.capacity)
            else:
                rec = ring.get_record()
            seq = int(rec["seq"])
            reads += 1
            if int(rec["src"]) != k or not np.array_equal(rec["data"], _pattern(k, seq, plan.payload)):
                torn += 1
            elif seq < seen - 1:
                stale += 1
            newest[k] = max(newest[k], seq)
    out.put(("reads", reads, torn, stale))


def _consumer(path: str, plan: Plan, out: Any) -> None:
    fd, mm = _open(path, _areas(plan)[2])
    queue = _queue(plan, mm, fd)
    expect = {plan.rings + p: 0 for p in range(plan.producers)}
    total, errors = plan.per_writer() * plan.producers, 0
    received = 0
    deadline = time.monotonic() + plan.timeout_s
    while received < total and time.monotonic() < deadline:
        if not queue.wait(0.001):  # no cross-process notifier here: poll
            continue
        for req in queue.get_all():
            received += 1
            src, seq = int(req["src"]), int(req["seq"])
            if expect.get(src) != seq or not np.array_equal(req["data"], _pattern(src, seq, plan.payload)):
                errors += 1
            expect[src] = seq + 1
    out.put(("queue", received, errors))


def stress(plan: Plan | None = None, **fields: Any) -> Report:
    """Run the stress test in fresh processes (spawned: the same on Linux, macOS and under QEMU)."""
    plan = plan or Plan(**fields)
    report = Report(plan=asdict(plan))
    size = _areas(plan)[2]
    fd, path = tempfile.mkstemp(prefix="rio-ordering-", dir=host.shm_dir())
    try:
        os.ftruncate(fd, size)
        ctx = mp.get_context("spawn")
        out = ctx.Queue()
        # readers and the consumer first, so they are watching before the writers start
        procs = [ctx.Process(target=_ring_reader, args=(path, plan, out)) for _ in range(plan.readers)]
        if plan.producers:
            procs.append(ctx.Process(target=_consumer, args=(path, plan, out)))
        procs += [ctx.Process(target=_writer, args=(path, plan, src, out))
                  for src in range(plan.rings + plan.producers)]
        t0 = time.monotonic()
        for proc in procs:
            proc.start()
        for _ in procs:
            try:
                msg = out.get(timeout=plan.timeout_s + 30)
            except Exception:
                report.problems.append("a stress process sent no result (it crashed or hung)")
                break
            if msg[0] == "written":
                report.written += msg[1]
            elif msg[0] == "reads":
                report.reads += msg[1]
                report.torn += msg[2]
                report.stale += msg[3]
            else:
                report.queue_received += msg[1]
                report.queue_errors += msg[2]
        for proc in procs:
            proc.join(10)
            if proc.exitcode != 0:
                report.problems.append(f"process {proc.name} ended with exit code {proc.exitcode}")
                proc.kill()
        report.seconds = time.monotonic() - t0
        expected_queue = plan.per_writer() * plan.producers
        if report.queue_received != expected_queue:
            report.problems.append(f"the queue consumer got {report.queue_received} of {expected_queue} requests")
    finally:
        os.close(fd)
        os.unlink(path)
    return report


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m rio.conformance.ordering", description=__doc__.split("\n")[0])
    for name, default in asdict(Plan()).items():
        if isinstance(default, bool):
            ap.add_argument(f"--{name.replace('_', '-')}", action="store_true", default=default)
        else:
            ap.add_argument(f"--{name.replace('_', '-')}", type=type(default), default=default)
    ap.add_argument("--json", action="store_true", help="print the report as JSON")
    args = vars(ap.parse_args(argv))
    as_json = args.pop("json")
    report = stress(Plan(**args))
    if as_json:
        print(json.dumps({**asdict(report), "ok": report.ok}))
    else:
        print(f"{report.machine}: {report.written} samples written, {report.reads} ring reads "
              f"({report.torn} torn, {report.stale} stale), {report.queue_received} requests "
              f"({report.queue_errors} lost/torn/out of order) in {report.seconds:.1f} s")
        for p in report.problems:
            print("problem:", p)
        print("PASS" if report.ok else "FAIL")
    return 0 if report.ok or args["unchecked"] else 1


if __name__ == "__main__":
    sys.exit(main())
