"""`Reservoir`: a run's percentiles in bounded memory, its count, mean and extremes exact."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rio.control.reservoir import Reservoir


def test_below_its_size_it_keeps_every_value():
    r = Reservoir(size=10)
    assert r.percentile(50) is None and r.mean is None and len(r) == 0
    for x in (3.0, 1.0, 2.0):
        r.add(x)
    assert sorted(r.values()) == [1.0, 2.0, 3.0] and r.percentile(50) == 2.0
    assert r.count == 3 and r.mean == 2.0 and (r.min, r.max) == (1.0, 3.0)


def test_a_long_run_stays_bounded_and_its_percentiles_hold():
    rng = np.random.default_rng(1)
    xs = rng.exponential(1.0, 300_000)
    xs[123_456] = 1e6  # one terrible tick: a sample may miss it, max must not
    r = Reservoir(size=20_000)
    for x in xs:
        r.add(x)
    assert len(r.values()) == 20_000 and r.count == len(xs)
    assert r.max == 1e6 and r.min == xs.min() and r.mean == pytest.approx(xs.mean())
    for q in (50, 90, 99):
        true = np.percentile(xs, q)
        assert r.percentile(q) == pytest.approx(true, rel=0.05), q


def test_undefined_values_are_counted_not_sampled():
    r = Reservoir(size=4)
    r.add(float("nan"))
    r.add(math.inf)
    r.add(2.0)
    assert r.count == 3 and len(r) == 1 and r.max == 2.0 and r.mean == 2.0
    with pytest.raises(ValueError, match="at least 1"):
        Reservoir(size=0)
