"""The middleware conformance kit is shipped as a pytest plugin and catches broken middlewares.

Broken variants of the thread middleware (a client ring buffer frozen on its first sample, a client
that silently drops requests) run through the kit with pytester: the cases that check what they
break fail, for the reason they check, while the unbroken thread middleware passes the same run.
"""

from __future__ import annotations

import subprocess
import sys
from importlib.metadata import entry_points

import pytest

import rio.conformance.middleware  # noqa: F401 - loaded before the in-process pytester runs, which keep it

from .conftest import kit_outcomes

pytest_plugins = ["pytester"]

KIT_CASES = 23  # cases per middleware, the parametrized one counted once per parameter set
# what a thread middleware cannot take: no server process to kill, no network protocol to flood
THREAD_SKIPS = {"test_sigkill_reported_within_one_second_and_cleaned_up", "test_flood_of_slow_calls_from_many_peers",
                "test_flood_of_slow_calls_from_one_peer", "test_flood_of_requests"}

BROKEN_MIDDLEWARES = '''
import numpy as np
from rio.conformance.middleware import MiddlewareConformance
from rio.middleware.thread import ThreadMiddleware


class FrozenRing:
    """Client ring buffer that keeps serving the first sample it read: a mirror that stopped updating."""

    def __init__(self, rb):
        self._rb, self._rec = rb, None

    def __getattr__(self, name):
        return getattr(self._rb, name)

    def get(self, out=None, *, copy=True):
        if self._rec is None:
            self._rec = self._rb.get_record()
        d = self._rb.layout.to_dict(self._rec.copy(), copy=False)
        if out is None:
            return d
        for n, v in d.items():
            if n in out:
                np.copyto(out[n], v)
            else:
                out[n] = v
        return out


class LossyQueue:
    """Client request queue that validates every request but silently drops one in 50."""

    def __init__(self, q):
        self._q, self._n = q, 0

    def __getattr__(self, name):
        return getattr(self._q, name)

    def put(self, values):
        self._n += 1
        if self._n % 50 == 0:
            self._q.layout.encode(values, fill_timestamp=0.0)  # still rejects bad requests
            return
        self._q.put(values)


class FrozenThread(ThreadMiddleware):
    name = "frozen-thread"

    def make_client(self, node, layouts, address):
        client = super().make_client(node, layouts, address)
        if client.ring_buffer is not None:
            client.ring_buffer = FrozenRing(client.ring_buffer)
        return client


class LossyThread(ThreadMiddleware):
    name = "lossy-thread"

    def make_client(self, node, layouts, address):
        client = super().make_client(node, layouts, address)
        if client.request_queue is not None:
            client.request_queue = LossyQueue(client.request_queue)
        return client


class TestSound(MiddlewareConformance):
    middleware = ThreadMiddleware()


class TestFrozen(MiddlewareConformance):
    middleware = FrozenThread()
    wait_s = 0.5  # its failures are waits that time out


class TestLossy(MiddlewareConformance):
    middleware = LossyThread()
'''


def test_pytest11_entry_point_is_registered():
    plugins = {ep.name: ep.value for ep in entry_points(group="pytest11")}
    assert plugins.get("rio") == "rio.conformance.pytest_plugin"


def test_plugin_import_is_cheap():
    """pytest imports the plugin in every run of every project with rio-core installed."""
    code = ("import sys, rio.conformance.pytest_plugin; "
            "print(sorted(m for m in ('numpy', 'zmq', 'zenoh', 'pydantic', 'rio.runtime.manager')\n"
            "             if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_kit_catches_broken_middlewares_and_passes_the_sound_one(pytester: pytest.Pytester):
    pytester.makepyfile(test_broken_middlewares=BROKEN_MIDDLEWARES)
    res = kit_outcomes(pytester.inline_run("-p", "no:cacheprovider"))

    sound = res["TestSound"]
    assert len(sound) == KIT_CASES, sound
    assert {c for c, o in sound.items() if o != "passed"} == THREAD_SKIPS
    assert all(sound[c] == "skipped" for c in THREAD_SKIPS), sound

    frozen = res["TestFrozen"]
    stale = {"test_latest_state_advances_and_last_k_is_ordered", "test_request_reaches_node_state",
             *(c for c in frozen if c.startswith("test_bad_requests_rejected_node_keeps_serving[") and
               not c.endswith(" text"))}
    assert len(stale) == 2 + 6
    assert all(frozen[c] == "failed" for c in stale), frozen
    assert "timed out waiting for new samples" in frozen["test_latest_state_advances_and_last_k_is_ordered text"]
    assert "timed out waiting for request applied" in frozen["test_request_reaches_node_state text"]

    lossy = res["TestLossy"]
    assert lossy["test_two_clients_concurrent_requests_none_lost"] == "failed", lossy
    assert "timed out waiting for all requests handled" in lossy["test_two_clients_concurrent_requests_none_lost text"]
    # dropping one request in 50 is invisible to the cases that send fewer: only the counting case sees it
    assert {c for c, o in lossy.items() if o == "failed"} == {"test_two_clients_concurrent_requests_none_lost"}


def test_rio_middleware_option_runs_the_kit_without_a_file(pytester: pytest.Pytester):
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "--rio-middleware", "thread")
    result.stdout.fnmatch_lines(["rio: middleware conformance kit on 'thread'"])
    result.assert_outcomes(passed=KIT_CASES - len(THREAD_SKIPS), skipped=len(THREAD_SKIPS))


def test_kit_module_without_a_middleware_skips_with_a_reason(pytester: pytest.Pytester):
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "-rs", "--pyargs", "rio.conformance.middleware")
    result.assert_outcomes(skipped=KIT_CASES)
    result.stdout.fnmatch_lines(["*no middleware to test*--rio-middleware NAME*"])
