"""Per-process CPU, RAM and GPU memory over a run: the RIO paper's Table III, measured, not guessed.

A daemon thread polls psutil (and NVML where an NVIDIA GPU exists) every `period_s`, so the sampled
processes pay nothing; the sampler's own cost shows up in the loop process's row. A process that exits
mid-run keeps the samples it had. psutil and nvidia-ml-py come with `pip install 'rio-core[profile]'`.
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass, field
from typing import Any

from rio import clock
from rio.profiling.trace import Trace

log = logging.getLogger("rio.profiling")

__all__ = ["ProcessSampler", "ProcessReading", "children_of"]

_EXTRA = "pip install 'rio-core[profile]'"
_MB = 1024 * 1024


def _psutil() -> Any:
    try:
        import psutil
    except ImportError:
        raise ImportError(f"per-process CPU/RAM sampling needs psutil: {_EXTRA}") from None
    return psutil


def children_of(pid: int) -> dict[str, int]:
    """A process's descendants as {"<name> <pid>": pid} (node processes of a ServerManager, say)."""
    psutil = _psutil()
    out = {}
    for child in psutil.Process(pid).children(recursive=True):
        try:
            out[f"{child.name()} {child.pid}"] = child.pid
        except psutil.NoSuchProcess:
            continue
    return out


class ProcessReading:
    """CPU % and RSS of one process, each reading covering the time since the previous one: the one
    psutil reading that the profile's sampler and `rio top` both take."""

    def __init__(self, pid: int, psutil: Any = None):
        self.pid = pid
        self._ps = psutil or _psutil()
        try:
            self.proc: Any = self._ps.Process(pid)
            self.proc.cpu_percent(None)  # primes the counter: psutil's first call always returns 0
        except self._ps.NoSuchProcess:
            self.proc = None

    @property
    def gone(self) -> bool:
        return self.proc is None

    def read(self) -> tuple[float, float] | None:
        """(CPU %, RSS MB) now, or None once the process is gone (or hidden from us)."""
        if self.proc is None:
            return None
        try:
            with self.proc.oneshot():
                return self.proc.cpu_percent(None), self.proc.memory_info().rss / _MB
        except (self._ps.NoSuchProcess, self._ps.ZombieProcess, self._ps.AccessDenied):
            self.proc = None
            return None


@dataclass
class _Series:
    label: str
    pid: int
    proc: ProcessReading
    cpu: list[float] = field(default_factory=list)
    rss_mb: list[float] = field(default_factory=list)
    gpu_mb: list[float] = field(default_factory=list)
    gone: bool = False


class _Gpu:
    """NVML handles, or nothing when there is no NVIDIA driver or pynvml is not installed."""

    def __init__(self) -> None:
        self.nvml: Any = None
        self.handles: list[Any] = []
        self.names: list[str] = []
        self.util: list[float] = []
        self.mem_used_mb: list[float] = []
        try:
            import pynvml

            pynvml.nvmlInit()
            self.handles = [pynvml.nvmlDeviceGetHandleByIndex(i) for i in range(pynvml.nvmlDeviceGetCount())]
            self.names = [_text(pynvml.nvmlDeviceGetName(h)) for h in self.handles]
            self.nvml = pynvml
        except Exception as e:  # ImportError, NVMLError (no driver / no device): no GPU columns
            log.debug("no GPU sampling: %s", e)
            self.handles = []

    def sample(self) -> dict[int, float]:
        """Whole-GPU utilisation (mean over devices) into `util`, and GPU memory (MB) per pid."""
        if not self.handles:
            return {}
        nv = self.nvml
        per_pid: dict[int, float] = {}
        util: list[float] = []
        used = 0.0
        for h in self.handles:
            try:
                util.append(float(nv.nvmlDeviceGetUtilizationRates(h).gpu))
                used += nv.nvmlDeviceGetMemoryInfo(h).used / _MB
                procs = list(nv.nvmlDeviceGetComputeRunningProcesses(h))
                procs += list(nv.nvmlDeviceGetGraphicsRunningProcesses(h))
            except Exception as e:  # a device query that fails once (e.g. not supported in a VM)
                log.debug("GPU sample failed: %s", e)
                continue
            for p in procs:
                mem = getattr(p, "usedGpuMemory", None)
                if mem is not None:
                    per_pid[p.pid] = per_pid.get(p.pid, 0.0) + mem / _MB
        if util:
            self.util.append(sum(util) / len(util))
            self.mem_used_mb.append(used)
        return per_pid

    def close(self) -> None:
        if self.nvml is not None:
            try:
                self.nvml.nvmlShutdown()
            except Exception:
                pass
            self.nvml, self.handles = None, []


def _text(v: Any) -> str:
    return v.decode() if isinstance(v, bytes) else str(v)


class ProcessSampler:
    """Samples CPU %, RSS and (where an NVIDIA GPU exists, via pynvml) GPU memory per process, plus
    whole-GPU utilisation, every `period_s` in a daemon thread.

    CPU % is psutil's: 100 is one core busy, so a multi-threaded process can exceed 100. With `trace`,
    every sample also becomes counter events there ("<label> CPU %", "<label> RSS MB", "GPU util %"),
    drawn by Perfetto as graphs under the trace's process.
    """

    #: False for the stand-in `Profile` uses when psutil is missing: it accepts `add` and samples nothing.
    available = True

    def __init__(self, processes: dict[str, int] | None = None, period_s: float = 0.2, trace: Trace | None = None):
        self._psutil: Any = _psutil() if self.available else None
        self.period_s = float(period_s)
        self.trace = trace
        self._series: dict[str, _Series] = {}
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._gpu: _Gpu | None = None
        self.gpu_names: list[str] = []
        for label, pid in (processes or {}).items():
            self.add(label, pid)

    def add(self, label: str, pid: int) -> None:
        """Watch one more process from now on (its first CPU reading covers the time since `add`)."""
        ps = self._psutil
        if ps is None:
            return
        proc = ProcessReading(pid, ps)
        if proc.gone:
            log.warning("not sampling '%s': no process %d", label, pid)
        with self._lock:
            self._series[label] = _Series(label, pid, proc, gone=proc.gone)

    # -- lifecycle ----------------------------------------------------------------------------------
    def start(self) -> ProcessSampler:
        if self._thread is None and self.available:
            self._gpu = _Gpu()
            self.gpu_names = list(self._gpu.names)
            self._stop.clear()
            self._thread = threading.Thread(target=self._run, name="rio-profile-sampler", daemon=True)
            self._thread.start()
        return self

    def stop(self) -> None:
        if self._thread is not None:
            self._stop.set()
            self._thread.join(5.0)
            self._thread = None
        if self._gpu is not None:
            self._gpu.close()

    def __enter__(self) -> ProcessSampler:
        return self.start()

    def __exit__(self, *exc: Any) -> None:
        self.stop()

    def _run(self) -> None:
        while not self._stop.wait(self.period_s):
            try:
                self.sample()
            except Exception:  # never let the sampler take the run down
                log.exception("profiling sampler")

    def sample(self) -> None:
        """Take one sample of every process now (the thread calls this every `period_s`)."""
        t = clock.now()
        gpu = self._gpu.sample() if self._gpu is not None else {}
        with self._lock:
            series = [s for s in self._series.values() if not s.gone]
        for s in series:
            reading = s.proc.read()
            if reading is None:
                s.gone = True  # exited: keep what it had
                continue
            cpu, rss = reading
            s.cpu.append(cpu)
            s.rss_mb.append(rss)
            if s.pid in gpu:
                s.gpu_mb.append(gpu[s.pid])
            if self.trace is not None:
                self.trace.counter(f"{s.label} CPU %", t, cpu=cpu)
                self.trace.counter(f"{s.label} RSS MB", t, rss=rss)
        if self.trace is not None and self._gpu is not None and self._gpu.util:
            self.trace.counter("GPU util %", t, util=self._gpu.util[-1])

    # -- results ------------------------------------------------------------------------------------
    @property
    def has_gpu(self) -> bool:
        return bool(self.gpu_names)

    def rows(self) -> list[dict[str, Any]]:
        """One dict per process: label, pid, cpu_pct_mean/max, rss_mb_mean/max, gpu_mem_mb_max, samples."""
        with self._lock:
            series = list(self._series.values())
        rows = []
        for s in series:
            n = len(s.cpu)
            rows.append({
                "label": s.label, "pid": s.pid,
                "cpu_pct_mean": sum(s.cpu) / n if n else None, "cpu_pct_max": max(s.cpu) if n else None,
                "rss_mb_mean": sum(s.rss_mb) / n if n else None, "rss_mb_max": max(s.rss_mb) if n else None,
                "gpu_mem_mb_max": (max(s.gpu_mb) if s.gpu_mb else 0.0) if self.has_gpu else None,
                "samples": n,
            })
        return rows

    def gpu_summary(self) -> dict[str, Any] | None:
        """Whole-GPU utilisation and memory in use over the run, or None without an NVIDIA GPU."""
        g = self._gpu
        if not self.has_gpu or g is None:
            return None
        u, m = g.util, g.mem_used_mb
        return {"devices": self.gpu_names, "util_pct_mean": sum(u) / len(u) if u else None,
                "util_pct_max": max(u) if u else None, "mem_used_mb_max": max(m) if m else None,
                "samples": len(u)}

    def table(self) -> str:
        """An aligned text table, one row per process, and a GPU line."""
        head = ["process", "pid", "CPU % mean", "CPU % max", "RSS MB mean", "RSS MB max", "GPU MB max", "samples"]
        keys = ["label", "pid", "cpu_pct_mean", "cpu_pct_max", "rss_mb_mean", "rss_mb_max", "gpu_mem_mb_max",
                "samples"]
        body = [[_cell(r[k]) for k in keys] for r in self.rows()]
        widths = [max(len(c) for c in col) for col in zip(head, *body, strict=True)]
        lines = ["  ".join(c.ljust(w) if i == 0 else c.rjust(w)
                           for i, (c, w) in enumerate(zip(row, widths, strict=True))) for row in [head, *body]]
        lines.insert(1, "  ".join("-" * w for w in widths))
        g = self.gpu_summary()
        if g is None:
            lines.append("GPU: none found")
        else:
            lines.append(f"GPU: {', '.join(g['devices'])}: utilisation mean {_cell(g['util_pct_mean'])} %, "
                         f"max {_cell(g['util_pct_max'])} %; memory in use max {_cell(g['mem_used_mb_max'])} MB")
        return "\n".join(lines)


class _Unavailable(ProcessSampler):
    """Stands in for a sampler when psutil is missing, so a profiled run still writes its trace."""

    available = False

    def __init__(self, reason: str, period_s: float = 0.2):
        super().__init__(None, period_s)
        self.reason = reason

    def table(self) -> str:
        return f"process stats unavailable: {self.reason}"


def _cell(v: Any) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.1f}"
    return str(v)
