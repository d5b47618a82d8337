"""The fixed binary layout of a node's samples and requests.

A node declares `example_data` / `example_request` as dicts of numpy arrays and scalars. We turn each
into a numpy structured dtype: one sample is one record of fixed size. That single decision gives us
the ring-buffer slot, the request-queue slot, the shared-memory layout and the network wire format
(`record.tobytes()` / `np.frombuffer`) with no serializer and no pickling anywhere on the hot path.
"""

from __future__ import annotations

import zlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from rio.errors import InvalidRequest

TIMESTAMP = "timestamp"


def _check_fits(v: np.ndarray, ft: np.dtype, owner: str, name: str) -> None:
    """A value of a wider type than its field (an int64 into int8, a float64 into float32) must fit, or the
    cast would silently change it (300 into int8 arrives as 44; 1e300 into float32 as inf)."""
    if ft.kind in "iu" and v.size:
        info = np.iinfo(ft)
        lo, hi = v.min(), v.max()
        if lo < info.min or hi > info.max:
            bad = lo if lo < info.min else hi
            raise InvalidRequest(owner, name, f"value {bad} does not fit {ft} (range {info.min}..{info.max})")
    elif ft.kind == "f" and v.dtype.kind in "fiu":
        with np.errstate(over="ignore"):
            narrowed = v.astype(ft)
        if not np.array_equal(np.isfinite(narrowed), np.isfinite(v)):
            raise InvalidRequest(owner, name, f"value beyond {ft}'s range (max {np.finfo(ft).max:.3g})")


def _field_of(name: str, value: Any, owner: str) -> tuple[str, np.dtype, tuple[int, ...]]:
    arr = np.asarray(value)
    if arr.dtype.kind not in "biufc":
        raise TypeError(
            f"node '{owner}': example field '{name}' has dtype {arr.dtype}; only numeric and bool "
            "arrays or scalars have a fixed size (encode text as a uint8 array)"
        )
    return (name, arr.dtype, arr.shape)


class Layout:
    """Structured dtype built from an example dict, plus validation against it."""

    def __init__(self, example: Mapping[str, Any], *, owner: str, what: str = "sample",
                 add_timestamp: bool = True):
        if not isinstance(example, Mapping) or not example:
            raise TypeError(f"node '{owner}': example {what} must be a non-empty dict of arrays/scalars")
        self.owner, self.what = owner, what
        fields = [_field_of(str(k), v, owner) for k, v in example.items()]
        if add_timestamp and TIMESTAMP not in example:
            fields.append((TIMESTAMP, np.dtype(np.float64), ()))
        self.dtype = np.dtype(fields, align=True)
        assert self.dtype.names is not None  # a structured dtype always has field names
        self.names: tuple[str, ...] = self.dtype.names
        self.itemsize = self.dtype.itemsize
        self.fingerprint = zlib.crc32(repr(self.dtype.descr).encode())
        self._float_fields = tuple(n for n in self.names if self.dtype[n].base.kind in "fc")
        self._shapes = {n: self.dtype[n].shape for n in self.names}

    def describe(self) -> dict[str, tuple[str, tuple[int, ...]]]:
        return {n: (self.dtype[n].base.str, self._shapes[n]) for n in self.names}

    def empty(self, n: int | None = None) -> np.ndarray:
        return np.zeros(() if n is None else (n,), dtype=self.dtype)

    def encode(self, values: Mapping[str, Any], *, fill_timestamp: float | None = None,
               check_finite: bool = True) -> np.ndarray:
        """Validate `values` and pack them into one record. Raises InvalidRequest naming the field."""
        if not isinstance(values, Mapping):
            raise InvalidRequest(self.owner, None, f"expected a dict, got {type(values).__name__}")
        rec = np.zeros((), dtype=self.dtype)
        missing = [n for n in self.names if n not in values and not (n == TIMESTAMP and fill_timestamp is not None)]
        if missing:
            raise InvalidRequest(self.owner, missing[0], f"missing (expected keys {list(self.names)})")
        for key in values:
            if key not in self._shapes:
                raise InvalidRequest(self.owner, str(key), f"unknown key (expected keys {list(self.names)})")
        for n in self.names:
            if n not in values:
                rec[n] = fill_timestamp
                continue
            v = np.asarray(values[n])
            want = self._shapes[n]
            if v.shape != want:
                raise InvalidRequest(self.owner, n, f"expected shape {want}, got {v.shape}")
            ft = self.dtype[n].base
            integers = v.dtype.kind in "iu" and ft.kind in "iu"  # any integer that fits (checked below)
            if not integers and not np.can_cast(v.dtype, ft, casting="same_kind"):
                raise InvalidRequest(self.owner, n, f"expected dtype {ft}, got {v.dtype}")
            if check_finite and v.dtype.kind in "fc" and not np.isfinite(v).all():
                raise InvalidRequest(self.owner, n, "contains NaN or inf")
            if v.dtype != ft and not np.can_cast(v.dtype, ft, casting="safe"):
                _check_fits(v, ft, self.owner, n)
            rec[n] = v
        return rec

    def check_record(self, rec: np.ndarray) -> None:
        """Server-side re-check of a record that crossed a process or network boundary."""
        for n in self._float_fields:
            if not np.isfinite(rec[n]).all():
                raise InvalidRequest(self.owner, n, "contains NaN or inf")

    def decode_bytes(self, buf: bytes | memoryview) -> np.ndarray:
        if len(buf) != self.itemsize:
            raise InvalidRequest(self.owner, None, f"{self.what} of {len(buf)} bytes, layout needs {self.itemsize}")
        return np.frombuffer(buf, dtype=self.dtype, count=1)[0]

    def to_dict(self, rec: np.ndarray, *, copy: bool = True) -> dict[str, Any]:
        """Record (or array of records) -> dict of arrays; scalars come back as numpy scalars."""
        out = {}
        for n in self.names:
            v = rec[n]
            out[n] = v.copy() if copy and isinstance(v, np.ndarray) else v
        return out
