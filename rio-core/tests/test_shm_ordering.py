"""Shared memory stays correct where the CPU reorders memory (ARM): checked slots refuse torn and
stale copies, and the reordering stress test (`rio.conformance.ordering`) finds none accepted.

This machine is x86 (stores become visible in order), so the reorderings ARM allows are made here
by hand: slot data changed under an unchanged check, a counter bumped before its slot was written.
The stress test's own payload checks are independent of the slot checks, and its `unchecked` mode
shows they catch torn reads when the checks are bypassed.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from rio.conformance.ordering import stress
from rio.errors import RioError
from rio.runtime import slot_check
from rio.runtime.buffers import RequestQueue, RingBuffer
from rio.runtime.layout import Layout

LAYOUT = Layout({"x": 0.0, "v": np.zeros(4)}, owner="n")


def test_a_check_accepts_only_the_exact_sample_it_was_written_for():
    checks = np.zeros((2, slot_check.CHECK_WORDS), np.uint64)
    data = np.arange(16, dtype=np.uint8)
    slot_check.write_check(checks, 1, 41, data)
    assert slot_check.matches(checks, 1, 41, data.copy())
    assert not slot_check.matches(checks, 1, 40, data)  # stale: another sequence number
    torn = data.copy()
    torn[7] ^= 1
    assert not slot_check.matches(checks, 1, 41, torn)
    # a check torn between two writes: seq of one, checksum of another
    other = np.full(16, 3, np.uint8)
    checks[1, 0] = 42
    assert not slot_check.matches(checks, 1, 42, other) and not slot_check.matches(checks, 1, 41, data)


def test_ring_reader_waits_for_a_slot_whose_data_is_not_yet_visible():
    rb = RingBuffer(LAYOUT, 4)
    rb.put({"x": 1.0, "v": np.ones(4)})
    # what an ARM reader may see: the writer's counter bump for sample 1 before sample 1's data
    rb._count[0] = 2
    raw = rb._slots.raw
    with pytest.raises(RioError, match="no consistent sample"):
        rb.get()
    rec = LAYOUT.encode({"x": 2.0, "v": np.full(4, 2.0)}, fill_timestamp=0.0)
    rb._slots.write(1, rec)  # the data and its check arrive
    assert rb.get()["x"] == 2.0 and rb.get(copy=False)["x"] == 2.0
    assert rb.get_last_k(2)["x"].tolist() == [1.0, 2.0]
    raw[0, 0] ^= 0xFF  # sample 0 changed under its check: a window over it is refused, not returned
    with pytest.raises(RioError, match="no consistent sample"):
        rb.get_last_k(2)


def test_request_queue_consumer_takes_only_complete_requests_in_order():
    q = RequestQueue(LAYOUT, 4)
    q.put({"x": 1.0, "v": np.zeros(4)})
    q.put({"x": 2.0, "v": np.zeros(4)})
    q._slots.raw[1, 0] ^= 0xFF  # the second request's bytes are not (all) visible yet
    assert [r["x"] for r in q.get_all()] == [1.0]
    assert q.get_all() == [] and len(q) == 1  # still pending, not dropped
    q._slots.raw[1, 0] ^= 0xFF  # now they are
    assert [r["x"] for r in q.get_all()] == [2.0] and len(q) == 0


@pytest.mark.slow
def test_stress_accepts_no_torn_stale_lost_or_reordered_sample():
    samples = int(os.environ.get("RIO_STRESS_SAMPLES", "1000000"))
    report = stress(samples=samples, rings=2, readers=2, producers=3, payload=64, timeout_s=240)
    assert report.ok, report
    assert report.written >= samples * 0.99 and report.reads > 1000
    assert report.queue_received == report.plan["producers"] * (samples // 5)


def test_stress_sees_torn_reads_when_the_checks_are_bypassed():
    """The negative control: the same payload checks, reading as the buffers did before slot checks
    (trust the counter, copy the slot) with a tiny ring, the reader pausing half-way through each copy
    as a preempted reader would, so the writer laps it."""
    for _ in range(3):  # the writer and reader must overlap in time; on a loaded machine retry
        report = stress(samples=20000, rings=1, readers=1, producers=0, payload=1024, ring_capacity=2,
                        unchecked=True, timeout_s=120)
        assert not report.problems, report.problems
        if report.torn:
            return
    pytest.fail(f"no torn read seen in 3 unchecked runs: the stress test could not see one ({report})")
