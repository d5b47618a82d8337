"""Ring buffer and request queue semantics on plain memory (the same code runs on shared memory)."""

import threading

import numpy as np
import pytest

from rio.errors import QueueFull, RioError
from rio.runtime.buffers import RequestQueue, RingBuffer
from rio.runtime.layout import Layout


def ring(cap=8):
    return RingBuffer(Layout({"x": 0.0, "v": np.zeros(3)}, owner="n"), cap)


def test_empty_ring_buffer_says_so():
    with pytest.raises(RioError, match="published nothing"):
        ring().get()


def test_latest_and_last_k_wrap_around():
    rb = ring(8)
    for i in range(20):
        rb.put({"x": float(i), "v": np.full(3, i)})
    assert rb.count == 20
    assert rb.get()["x"] == 19.0
    last = rb.get_last_k(5)
    np.testing.assert_array_equal(last["x"], [15, 16, 17, 18, 19])
    assert last["v"].shape == (5, 3)
    with pytest.raises(ValueError):
        rb.get_last_k(8)  # must leave one slot for the writer


def test_last_k_pads_with_oldest_before_k_samples():
    rb = ring()
    rb.put({"x": 1.0, "v": np.zeros(3)})
    rb.put({"x": 2.0, "v": np.zeros(3)})
    np.testing.assert_array_equal(rb.get_last_k(4)["x"], [1, 1, 1, 2])


def test_zero_copy_views_are_read_only_and_out_fills_in_place():
    rb = ring()
    rb.put({"x": 1.0, "v": np.arange(3.0)})
    view = rb.get(copy=False)
    assert not view["v"].flags.writeable
    out = {"v": np.empty(3)}
    got = rb.get(out=out)
    assert got["v"] is out["v"]
    np.testing.assert_array_equal(out["v"], [0, 1, 2])


def test_reader_never_sees_a_torn_sample():
    rb = RingBuffer(Layout({"v": np.zeros(512)}, owner="n"), 4)
    rb.put({"v": np.zeros(512)})
    stop = threading.Event()

    def writer():
        i = 0
        while not stop.is_set():
            i += 1
            rb.put({"v": np.full(512, float(i))})

    t = threading.Thread(target=writer)
    t.start()
    try:
        for _ in range(3000):
            v = rb.get()["v"]
            assert v.min() == v.max(), "torn read"
    finally:
        stop.set()
        t.join()


def test_request_queue_order_and_get_all():
    q = RequestQueue(Layout({"a": 0}, owner="n", what="request"), 4)
    for i in range(3):
        q.put({"a": i})
    assert len(q) == 3
    assert [r["a"] for r in q.get_all()] == [0, 1, 2]
    assert q.get_all() == [] and q.get() is None


def test_request_queue_full_waits_then_raises():
    q = RequestQueue(Layout({"a": 0}, owner="grip", what="request"), 2, put_timeout=0.05)
    q.put({"a": 1})
    q.put({"a": 2})
    with pytest.raises(QueueFull, match="grip"):
        q.put({"a": 3})
    q.get()
    q.put({"a": 3})  # space again
    assert [r["a"] for r in q.get_all()] == [2, 3]


def test_request_queue_wait_wakes_on_put():
    q = RequestQueue(Layout({"a": 0}, owner="n", what="request"), 4)
    assert q.wait(0.01) is False
    threading.Timer(0.02, lambda: q.put({"a": 5})).start()
    assert q.wait(2.0) is True
    assert q.get()["a"] == 5


def test_put_bytes_rechecks_nan_on_the_receiving_side():
    lay = Layout({"a": 0.0}, owner="n", what="request")
    q = RequestQueue(lay, 4)
    rec = lay.empty()
    rec["a"] = np.nan
    with pytest.raises(Exception, match="NaN"):
        q.put_bytes(rec.tobytes())
    assert len(q) == 0 and q.rejected == 1
