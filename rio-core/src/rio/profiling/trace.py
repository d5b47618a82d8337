"""Spans on named tracks, written per process and merged into one Chrome/Perfetto trace.

Every process (the control loop, each node process, each node thread) records into its own `Trace`
and writes a *part file* when it ends; `merge_parts` joins them. Timestamps are `rio.clock.now()`,
which is system-wide monotonic on one machine, so parts from different processes line up without
any clock exchange.

Events are kept as packed arrays (24 bytes per span) rather than dicts, and capped at `max_events`
(further ones are counted as dropped), so profiling an hour-long 1 kHz run cannot exhaust memory.
"""

from __future__ import annotations

import base64
import binascii
import json
import logging
import os
import re
import sys
import threading
import uuid
from array import array
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from rio import clock

log = logging.getLogger("rio.profiling")

__all__ = ["Trace", "merge_parts", "load_trace", "read_part", "PART_SUFFIX", "MAX_EVENTS"]

#: Part files are `<process>-<pid>-<id>` + this; `merge_parts` picks up exactly these.
PART_SUFFIX = ".trace.json"
#: Default cap on events per Trace (about 50 MB of packed spans).
MAX_EVENTS = 2_000_000
PART_FORMAT = "rio-trace-part/1"
_REQUIRED = ("ph", "ts", "pid", "tid", "name")


class Trace:
    """Spans on named tracks, in rio.clock time (clock.now(), seconds).

    `process` labels the Chrome process group this trace forms ("loop", "node arm"). A track is a row
    inside it; tracks get thread ids in first-use order, so a row's position is stable within a run.
    `span` is safe to call from several threads.
    """

    def __init__(self, process: str = "loop", max_events: int = MAX_EVENTS):
        self.process = process
        self.pid = os.getpid()
        self.max_events = int(max_events)
        self.dropped = 0
        self._lock = threading.Lock()
        self._tracks: dict[str, int] = {}
        self._keys: dict[tuple[str, int, str], int] = {}  # (ph, tid, name) -> index into _key_list
        self._key_list: list[tuple[str, int, str]] = []
        self._t0 = array("d")
        self._t1 = array("d")
        self._key = array("q")
        self._args: dict[int, dict[str, Any]] = {}  # event index -> args, only for events that have them
        self._id = uuid.uuid4().hex[:8]

    def __len__(self) -> int:
        return len(self._key)

    def tracks(self) -> dict[str, int]:
        """Track name -> Chrome thread id, in first-use order."""
        with self._lock:
            return dict(self._tracks)

    def _key_of(self, ph: str, track: str, name: str) -> int:
        tid = 0 if ph == "C" else self._tracks.get(track)  # counters belong to the process, not a track
        if tid is None:
            tid = self._tracks[track] = len(self._tracks) + 1  # tid 0 is left to process-level events
        k = (ph, tid, name)
        i = self._keys.get(k)
        if i is None:
            i = self._keys[k] = len(self._key_list)
            self._key_list.append(k)
        return i

    def _add(self, ph: str, track: str, name: str, t0: float, t1: float, args: dict[str, Any] | None) -> None:
        with self._lock:
            if len(self._key) >= self.max_events:
                self.dropped += 1
                return
            if args:
                self._args[len(self._key)] = args
            self._key.append(self._key_of(ph, track, name))
            self._t0.append(t0)
            self._t1.append(t1)

    def span(self, track: str, name: str, t_begin: float, t_end: float, **args: Any) -> None:
        """A complete event ("ph": "X") from `t_begin` to `t_end` (clock.now() seconds)."""
        self._add("X", track, name, t_begin, t_end, args or None)

    @contextmanager
    def phase(self, track: str, name: str, **args: Any) -> Iterator[None]:
        """Time the block (even when it raises) as one span."""
        with self._lock:  # the track's row is placed where the block starts (an outer phase above an inner)
            self._key_of("X", track, name)
        t0 = clock.now()
        try:
            yield
        finally:
            self._add("X", track, name, t0, clock.now(), args or None)

    def counter(self, name: str, t: float, **values: float) -> None:
        """A counter sample ("ph": "C"): each keyword is one series of the counter `name`."""
        self._add("C", "", name, t, t, {k: float(v) for k, v in values.items()})

    def _snapshot(self) -> _Snapshot:
        with self._lock:
            n = len(self._key)
            return _Snapshot(self.process, self.pid, self.dropped, dict(self._tracks), list(self._key_list),
                             self._t0[:n], self._t1[:n], self._key[:n], dict(self._args))

    def events(self) -> list[dict[str, Any]]:
        """Chrome trace events (ts/dur in microseconds of clock time), led by this process's metadata."""
        snap = self._snapshot()
        out = _metadata(snap.pid, snap.process, snap.tracks, snap.dropped)
        for i, (t0, t1, k) in enumerate(zip(snap.t0, snap.t1, snap.key, strict=True)):
            ph, tid, name = snap.keys[k]
            ev: dict[str, Any] = {"ph": ph, "name": name, "ts": t0 * 1e6, "pid": snap.pid, "tid": tid}
            if ph == "X":
                ev["dur"] = max(0.0, (t1 - t0) * 1e6)
            a = snap.args.get(i)
            if a is not None:
                ev["args"] = a
            out.append(ev)
        return out

    def write_part(self, directory: str | os.PathLike[str]) -> Path:
        """This trace to DIR/<process>-<pid>-<id>.trace.json, atomically (a reader never sees half).

        The times are stored packed (base64 float64), not as Chrome events: a node writes its part while
        the ServerManager waits a few seconds for it to stop, and a million spans must fit in that.
        """
        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", self.process).strip("_") or "process"
        path = d / f"{safe}-{self.pid}-{self._id}{PART_SUFFIX}"
        _atomic_write(path, json.dumps(self._snapshot().to_json(), separators=(",", ":")))
        return path


class _Snapshot:
    """One Trace's content, packed: what a part file holds."""

    def __init__(self, process: str, pid: int, dropped: int, tracks: dict[str, int], keys: list[tuple[str, int, str]],
                 t0: Any, t1: Any, key: Any, args: dict[int, dict[str, Any]]):
        self.process, self.pid, self.dropped, self.tracks, self.keys = process, pid, dropped, tracks, keys
        self.t0, self.t1, self.key, self.args = t0, t1, key, args

    def to_json(self) -> dict[str, Any]:
        def pack(a: Any) -> str:
            return base64.b64encode(a.tobytes()).decode("ascii")

        return {"format": PART_FORMAT, "process": self.process, "pid": self.pid, "dropped": self.dropped,
                "clock": "rio.clock.now", "byteorder": sys.byteorder, "tracks": self.tracks,
                "keys": [list(k) for k in self.keys], "t0": pack(self.t0), "t1": pack(self.t1),
                "key": pack(self.key), "args": {str(i): a for i, a in self.args.items()}}

    @classmethod
    def from_json(cls, doc: Any) -> _Snapshot:
        import numpy as np

        if not isinstance(doc, dict) or doc.get("format") != PART_FORMAT:
            raise ValueError(f"not a rio trace part (format {PART_FORMAT!r})")
        order = "<" if doc.get("byteorder", "little") == "little" else ">"

        def unpack(field: str, dtype: str) -> Any:
            return np.frombuffer(base64.b64decode(doc[field]), dtype=order + dtype)

        t0, t1, key = unpack("t0", "f8"), unpack("t1", "f8"), unpack("key", "i8")
        keys = [(str(ph), int(tid), str(name)) for ph, tid, name in doc["keys"]]
        if not len(t0) == len(t1) == len(key) or (len(key) and not 0 <= int(key.min()) <= int(key.max()) < len(keys)):
            raise ValueError("inconsistent event arrays")
        return cls(str(doc["process"]), int(doc["pid"]), int(doc.get("dropped", 0)),
                   {str(k): int(v) for k, v in doc["tracks"].items()}, keys, t0, t1, key,
                   {int(i): a for i, a in doc.get("args", {}).items()})


def _atomic_write(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex[:6]}.tmp")
    try:
        tmp.write_text(text)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def _metadata(pid: int, process: str, tracks: dict[str, int], dropped: int, sort: int | None = None
              ) -> list[dict[str, Any]]:
    name = f"{process} (dropped {dropped} events)" if dropped else process
    out: list[dict[str, Any]] = [{"ph": "M", "name": "process_name", "ts": 0, "pid": pid, "tid": 0,
                                  "args": {"name": name}}]
    if sort is not None:
        out.append({"ph": "M", "name": "process_sort_index", "ts": 0, "pid": pid, "tid": 0,
                    "args": {"sort_index": sort}})
    for track, tid in tracks.items():
        out.append({"ph": "M", "name": "thread_name", "ts": 0, "pid": pid, "tid": tid, "args": {"name": track}})
        out.append({"ph": "M", "name": "thread_sort_index", "ts": 0, "pid": pid, "tid": tid,
                    "args": {"sort_index": tid}})
    return out


def read_part(path: str | os.PathLike[str]) -> _Snapshot:
    """One part file, checked; ValueError when it is not one."""
    try:
        return _Snapshot.from_json(json.loads(Path(path).read_text()))
    except (KeyError, TypeError, json.JSONDecodeError, binascii.Error) as e:
        raise ValueError(f"not a readable rio trace part: {type(e).__name__}: {e}") from None


def merge_parts(directory: str | os.PathLike[str], out_path: str | os.PathLike[str]) -> dict[str, Any]:
    """Every part file in `directory` -> one Chrome trace at `out_path`, which is also returned.

    Each part becomes one process group (parts with the same label and OS pid share one), its tracks
    named rows; times are shifted so the earliest event is at 0. Unreadable parts are skipped with a
    warning and listed under otherData.skipped_parts.
    """
    import numpy as np

    d = Path(directory)
    parts, skipped = [], []
    for p in sorted(d.glob(f"*{PART_SUFFIX}")):
        try:
            parts.append(read_part(p))
        except (OSError, ValueError) as e:
            log.warning("skipping trace part %s: %s", p, e)
            skipped.append(f"{p.name}: {e}")
    if not parts:
        raise ValueError(f"no readable trace parts (*{PART_SUFFIX}) in {d}")
    parts.sort(key=lambda s: (s.process != "loop", s.process, s.pid))  # the loop first, then nodes by name
    groups: dict[tuple[str, int], tuple[int, dict[str, int]]] = {}  # (label, os pid) -> (chrome pid, tracks)
    dropped: dict[str, int] = {}
    keys: dict[tuple[str, int, int, str], int] = {}  # (ph, pid, tid, name) over all parts
    t0s, t1s, ks = [], [], []
    args: dict[int, dict[str, Any]] = {}
    offset = 0
    for part in parts:
        pid, tracks = groups.setdefault((part.process, part.pid), (len(groups) + 1, {}))
        if part.dropped:
            dropped[part.process] = dropped.get(part.process, 0) + part.dropped
        remap = {tid: tracks.setdefault(track, len(tracks) + 1) for track, tid in part.tracks.items()}
        lut = np.array([keys.setdefault((ph, pid, remap.get(tid, tid), name), len(keys))
                        for ph, tid, name in part.keys] or [0], dtype=np.int64)
        t0s.append(part.t0)
        t1s.append(part.t1)
        ks.append(lut[part.key])
        args.update({offset + i: a for i, a in part.args.items()})
        offset += len(part.key)
    t0, t1, k = np.concatenate(t0s), np.concatenate(t1s), np.concatenate(ks)
    origin = float(t0.min()) if len(t0) else 0.0
    order = np.argsort(t0, kind="stable")
    ts = np.round((t0[order] - origin) * 1e6, 3).tolist()
    dur = np.round(np.maximum(t1[order] - t0[order], 0.0) * 1e6, 3).tolist()
    key_list = list(keys)
    events: list[dict[str, Any]] = []
    for (label, _), (pid, tracks) in groups.items():
        events += _metadata(pid, label, tracks, dropped.get(label, 0), sort=pid)
    for j, i, t, du in zip(k[order].tolist(), order.tolist(), ts, dur, strict=True):
        ph, pid, tid, name = key_list[j]
        ev: dict[str, Any] = {"ph": ph, "name": name, "ts": t, "pid": pid, "tid": tid}
        if ph == "X":
            ev["dur"] = du
        a = args.get(i)
        if a is not None:
            ev["args"] = a
        events.append(ev)
    trace = {"traceEvents": events, "displayTimeUnit": "ms",
             "otherData": {"origin_us": origin * 1e6, "clock": "rio.clock.now", "dropped_events": dropped,
                           "skipped_parts": skipped, "processes": {label: os_pid for (label, os_pid) in groups}}}
    out = Path(out_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    _atomic_write(out, json.dumps(trace, separators=(",", ":")))
    return trace


def load_trace(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read a merged trace, checking it is what Chrome/Perfetto load; ValueError names the first problem."""
    p = Path(path)
    try:
        doc = json.loads(p.read_text())
    except json.JSONDecodeError as e:
        raise ValueError(f"{p}: not JSON ({e})") from None
    if not isinstance(doc, dict):
        raise ValueError(f"{p}: expected a JSON object with 'traceEvents', got {type(doc).__name__}")
    events = doc.get("traceEvents")
    if not isinstance(events, list):
        raise ValueError(f"{p}: 'traceEvents' is missing or not a list")
    for i, ev in enumerate(events):
        if not isinstance(ev, dict):
            raise ValueError(f"{p}: event {i} is not an object")
        missing = [k for k in _REQUIRED if k not in ev]
        if missing:
            raise ValueError(f"{p}: event {i} ({ev.get('name', '?')!r}) lacks {missing}")
        if ev["ph"] == "X" and not (isinstance(ev.get("dur"), (int, float)) and ev["dur"] >= 0):
            raise ValueError(f"{p}: span {i} ({ev['name']!r}) has no non-negative 'dur'")
    return doc
