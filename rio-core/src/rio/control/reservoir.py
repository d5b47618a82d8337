"""`Reservoir`: percentiles of a run of any length in bounded memory.

The control loop measures something every tick (wake-up lateness, tracking error, the age of each
action sent): a list grows ~50 MB an hour at 500 Hz, and an overnight evaluation or a teleop session
left running should not end in swap. A reservoir keeps a uniform random sample of at most `size`
values (Vitter's algorithm R) for percentiles — at the default 100 000 a p99 is off by well under a
tenth of a percentile — and the exact count, mean, min and max of everything added, since a single
worst tick is exactly what a sample can miss.
"""

from __future__ import annotations

import math
import random

import numpy as np


class Reservoir:
    def __init__(self, size: int = 100_000, seed: int = 0):
        if size < 1:
            raise ValueError(f"a reservoir holds at least 1 value, got size {size}")
        self._values = np.empty(size, dtype=np.float64)
        self._rng = random.Random(seed)
        self.count = 0
        self.total = 0.0
        self.min = math.inf
        self.max = -math.inf

    def add(self, x: float) -> None:
        """Add one value; NaN and inf are counted in `count` only (an undefined error is no sample)."""
        self.count += 1
        x = float(x)
        if not math.isfinite(x):
            return
        self.total += x
        self.min, self.max = min(self.min, x), max(self.max, x)
        n, size = self._finite, self._values.size
        if n < size:
            self._values[n] = x
        else:
            j = self._rng.randrange(n + 1)
            if j < size:
                self._values[j] = x
        self._finite = n + 1

    _finite = 0  # finite values added (the reservoir's own count)

    def __len__(self) -> int:
        """Finite values added."""
        return self._finite

    def values(self) -> np.ndarray:
        """The sample (every finite value while fewer than `size` were added), a copy."""
        return self._values[: min(self._finite, self._values.size)].copy()

    def percentile(self, q: float) -> float | None:
        """The q-th percentile (0-100) of the finite values added, or None before the first."""
        if not self._finite:
            return None
        return float(np.percentile(self._values[: min(self._finite, self._values.size)], q))

    @property
    def mean(self) -> float | None:
        return self.total / self._finite if self._finite else None
