"""`rio_unitree.testing.free_domain_id`: a test process asking for more domains than its range holds gets the
ones it handed out longest ago again (each still probed), instead of running out: a pytest-xdist worker draws
from half of the range and asks once per G1 test, and ran out in the middle of the suite."""

from __future__ import annotations

from rio_unitree import testing

from rio.machine.parallel import worker_share

#: Outside the 100..200 the other tests draw from, so their robots are never on these.
LO, HI = 220, 223


def test_domains_are_handed_out_again_the_longest_ago_first(monkeypatch):
    monkeypatch.setattr(testing, "_handed_out", type(testing._handed_out)())  # as in a fresh process
    share = list(worker_share(LO, HI))
    got = [testing.free_domain_id(lo=LO, hi=HI, listen_s=0.05) for _ in range(2 * len(share) + 1)]
    first = got[:len(share)]
    assert sorted(first) == share  # every domain of the share once before any again
    assert got[len(share):] == first + first[:1]  # then again, in the order they were first handed out
