"""One profiled run: switch node tracing on, sample processes, and write the results at the end.

Node servers learn that profiling is on from an environment variable rather than from an argument,
because they start deep inside `ServerManager` (in threads, or in spawned processes that inherit the
environment) and no code between a workflow and a node should have to pass a flag along. Each node
writes its own part file when its loop ends; `Profile.__exit__` merges them, so the Profile must close
after the nodes stop (open it outside the `ServerManager`).
"""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from rio.errors import ConfigError
from rio.profiling.stats import ProcessSampler, _Unavailable
from rio.profiling.trace import PART_SUFFIX, Trace, merge_parts

log = logging.getLogger("rio.profiling")

__all__ = ["PROFILE_ENV", "enable", "disable", "active_dir", "Profile"]

PROFILE_ENV = "RIO_PROFILE_DIR"
_active: Path | None = None


def enable(directory: str | os.PathLike[str]) -> None:
    """Make node runners started from now on (here, and in processes spawned later) record traces into
    `directory`."""
    global _active
    d = Path(directory).resolve()
    d.mkdir(parents=True, exist_ok=True)
    _active = d
    os.environ[PROFILE_ENV] = str(d)


def disable() -> None:
    global _active
    _active = None
    os.environ.pop(PROFILE_ENV, None)


def active_dir() -> Path | None:
    """Where part files go, or None when profiling is off (the flag here, else the inherited variable)."""
    if _active is not None:
        return _active
    v = os.environ.get(PROFILE_ENV)
    return Path(v) if v else None


class Profile:
    """`with Profile(out_dir) as prof:` — enable() for node processes started inside, a loop-side Trace
    (`prof.trace`), a ProcessSampler (`prof.sampler`, with this process added), and on exit:
    merge every part file (write the loop's own part first) into OUT/trace.json, OUT/timeline.png,
    OUT/stats.txt (the table) and OUT/stats.json (the rows); disable(). `prof.files` lists what was written;
    `prof.summary_lines()` -> short lines for a workflow's end summary (where the files are, the table).

    Nothing on exit raises: a missing optional dependency or a failed PNG becomes a line in
    `prof.warnings`, and trace.json is written before anything that could fail for such reasons.
    Without psutil, `prof.sampler` is a stand-in that samples nothing (`prof.sampler.available` is False).
    """

    def __init__(self, out_dir: str | os.PathLike[str], *, period_s: float = 0.2, title: str = "",
                 process: str = "loop"):
        self.out = Path(out_dir)
        self.parts = self.out / "parts"
        self.title = title
        self.period_s = period_s
        self.trace = Trace(process)
        self.sampler: ProcessSampler = _Unavailable("not started", period_s)
        self.files: list[Path] = []
        self.warnings: list[str] = []
        self.table = ""
        self._closed = False

    # -- during the run -----------------------------------------------------------------------------
    def __enter__(self) -> Profile:
        try:
            self.parts.mkdir(parents=True, exist_ok=True)
        except OSError as e:  # one line naming the folder, not a traceback after the station started
            raise ConfigError(f"{self.out}: cannot write the profile here ({e.strerror or e})") from None
        for old in self.parts.glob(f"*{PART_SUFFIX}"):  # a previous run into the same folder
            old.unlink()
        enable(self.parts)
        try:
            self.sampler = ProcessSampler({self.trace.process: os.getpid()}, self.period_s, trace=self.trace).start()
        except ImportError as e:  # no psutil: still trace
            self.sampler = _Unavailable(str(e), self.period_s)
            self.warnings.append(f"stats.txt/stats.json not written: {e}")
        return self

    def watch(self, label: str, pid: int) -> None:
        """Sample one more process (a policy server, a simulator) in the stats table."""
        self.sampler.add(label, pid)

    def watch_nodes(self, pids: Mapping[str, int]) -> None:
        """Sample node processes, e.g. `ServerManager.pids()`, labelled like their trace ("node <name>")."""
        for name, pid in pids.items():
            self.watch(f"node {name}", pid)

    # -- at the end ---------------------------------------------------------------------------------
    def __exit__(self, *exc: Any) -> None:
        self.close()

    def close(self) -> None:
        """Stop sampling and write everything (what __exit__ does); a second call does nothing."""
        if self._closed:
            return
        self._closed = True
        try:
            self._write()
        finally:
            disable()
        for w in self.warnings:
            log.warning("profile: %s", w)

    def _attempt(self, what: str, fn: Any) -> Any:
        try:
            return fn()
        except Exception as e:
            self.warnings.append(f"{what} not written: {type(e).__name__}: {e}")
            return None

    def _write(self) -> None:
        self.sampler.stop()
        merged = None
        if self._attempt("loop trace part", lambda: self.trace.write_part(self.parts)) is not None:
            merged = self._attempt("trace.json", lambda: merge_parts(self.parts, self.out / "trace.json"))
        if merged is not None:  # the trace first: nothing below can cost it
            self.files.append(self.out / "trace.json")
            from rio.profiling.timeline import write_timeline

            png = self._attempt("timeline.png", lambda: write_timeline(merged, self.out / "timeline.png", self.title))
            if png is not None:
                self.files.append(png)
        if self.sampler.available:
            self.table = self.sampler.table()
            self._attempt("stats", self._write_stats)

    def _write_stats(self) -> None:
        s = self.sampler
        (self.out / "stats.txt").write_text(self.table + "\n")
        doc = {"processes": s.rows(), "gpu": s.gpu_summary(), "period_s": s.period_s}
        (self.out / "stats.json").write_text(json.dumps(doc, indent=2) + "\n")
        self.files += [self.out / "stats.txt", self.out / "stats.json"]

    def summary_lines(self) -> list[str]:
        """Where the files are and the stats table, for a workflow's end summary."""
        lines = []
        if self.files:
            lines.append(f"profile written to {self.out}/: " + ", ".join(p.name for p in self.files))
            lines.append("  open trace.json in https://ui.perfetto.dev (or chrome://tracing)")
        else:
            lines.append(f"profile: nothing written to {self.out}")
        lines += ["  " + line for line in self.table.splitlines()]
        lines += [f"  warning: {w}" for w in self.warnings]
        return lines
