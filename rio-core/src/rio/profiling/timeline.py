"""A PNG per-node timeline (the RIO paper's Fig. 6) from a merged trace: one row per process and track.

The PNG is for a glance and for papers; the trace itself is for digging (ui.perfetto.dev). A 1 kHz
node over minutes has far more spans than a figure has pixels, so spans closer together than about a
pixel are merged into one bar and every bar is at least a pixel wide: the picture stays truthful about
where time went, renders in well under a second, and keeps the file small.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from rio.profiling.trace import load_trace

__all__ = ["write_timeline"]

_WIDTH_PX = 2400  # resolution bars are merged to (the figure is 16 in at 150 dpi)
_DETAIL_SPANS = 2000  # a row with more spans than this: whole-run busy fractions, plus a window of spans
_WINDOW_SPANS = 300  # about this many spans of the densest row in that window


def _rows(trace: dict[str, Any]) -> list[tuple[str, Any]]:
    """[(label "process / track", array of (start_ms, dur_ms)), ...] in process then track order."""
    import numpy as np

    procs: dict[int, str] = {}
    tracks: dict[tuple[int, int], str] = {}
    spans: dict[tuple[int, int], list[tuple[float, float]]] = {}
    for ev in trace["traceEvents"]:
        ph = ev.get("ph")
        if ph == "X":
            spans.setdefault((ev["pid"], ev["tid"]), []).append((ev["ts"] / 1e3, ev.get("dur", 0.0) / 1e3))
        elif ph == "M" and ev.get("name") == "process_name":
            procs[ev["pid"]] = str(ev["args"]["name"])
        elif ph == "M" and ev.get("name") == "thread_name":
            tracks[(ev["pid"], ev["tid"])] = str(ev["args"]["name"])
    rows = []
    for pid, tid in sorted(set(tracks) | set(spans)):
        a = np.asarray(spans.get((pid, tid), []), dtype=float).reshape(-1, 2)
        label = f"{procs.get(pid, f'pid {pid}')} / {tracks.get((pid, tid), f'tid {tid}')}"
        rows.append((label, a[np.argsort(a[:, 0], kind="stable")]))
    return rows


def _merge(bars: Any, px_ms: float) -> list[tuple[float, float]]:
    """Sorted (start, dur) bars -> bars merged where the gap is under a pixel, each at least a pixel wide."""
    import numpy as np

    if len(bars) == 0:
        return []
    start = bars[:, 0]
    end = np.maximum.accumulate(start + np.maximum(bars[:, 1], px_ms))
    first = np.flatnonzero(np.r_[True, start[1:] > end[:-1] + px_ms])
    last = np.r_[first[1:] - 1, len(bars) - 1]
    return list(zip(start[first].tolist(), (end[last] - start[first]).tolist(), strict=True))


def _busy(bars: Any, edges: Any) -> Any:
    """Fraction of each bin [edges[i], edges[i+1]) covered by spans, from the cumulative busy time."""
    import numpy as np

    s, e = np.sort(bars[:, 0]), np.sort(bars[:, 0] + bars[:, 1])
    cs, ce = np.r_[0.0, np.cumsum(s)], np.r_[0.0, np.cumsum(e)]
    ns, ne = np.searchsorted(s, edges, "right"), np.searchsorted(e, edges, "right")
    busy = ns * edges - cs[ns] - (ne * edges - ce[ne])  # time spent inside spans before each edge
    return np.clip(np.diff(busy) / np.diff(edges), 0.0, 1.0)


def write_timeline(trace: dict[str, Any] | str | os.PathLike[str], png_path: str | os.PathLike[str],
                   title: str = "") -> Path:
    """Draw `trace` (a merged trace dict, or its file) as a per-process, per-track timeline PNG.

    Short runs: every span as a bar. Long runs (a row over a few thousand spans): the whole run as
    busy fractions (how much of each instant a track spent in spans), above a window from the middle
    of the run where each span is a bar again.
    """
    try:
        import matplotlib
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise ImportError("the timeline PNG needs matplotlib: pip install 'rio-core[profile]'") from None
    import numpy as np

    doc = trace if isinstance(trace, dict) else load_trace(trace)
    rows = _rows(doc)
    spans = [a for _, a in rows if len(a)]
    # x covers the spans only: the time before the first one (nodes starting) would squeeze the run
    t0 = min((float(a[0, 0]) for a in spans), default=0.0)
    t1 = max(max((float((a[:, 0] + a[:, 1]).max()) for a in spans), default=t0 + 1.0), t0 + 1e-3)
    densest = max((len(a) for a in spans), default=0)
    detail = densest > _DETAIL_SPANS
    n = max(len(rows), 1)
    panel_in = 0.6 + 0.35 * n
    fig = Figure(figsize=(16, (2 * panel_in + 0.4) if detail else (panel_in + 0.4)), dpi=150)
    FigureCanvasAgg(fig)  # Agg, without touching pyplot's global backend: a file needs no display
    axes = fig.subplots(2, 1) if detail else [fig.add_subplot()]
    cmap = matplotlib.colormaps["tab10"]
    procs = list(dict.fromkeys(label.split(" / ")[0] for label, _ in rows))
    colors = [cmap(procs.index(label.split(" / ")[0]) % 10) for label, _ in rows]
    if detail:
        w = (t1 - t0) * _WINDOW_SPANS / densest
        mid = (t0 + t1) / 2
        w0, w1 = mid - w / 2, mid + w / 2
        edges = np.linspace(t0, t1, _WIDTH_PX // 2 + 1)
        for y, ((_, a), c) in enumerate(zip(rows, colors, strict=True)):
            if len(a):
                frac = _busy(a, edges)
                frac = np.where(frac > 0, np.maximum(frac, 0.06), 0.0)  # a busy bin stays visible
                axes[0].fill_between(edges, y + 0.4, y + 0.4 - 0.8 * np.r_[frac, frac[-1]], step="post",
                                     color=c, linewidth=0)
        axes[0].axvspan(w0, w1, color="k", alpha=0.12, linewidth=0)
        axes[0].set_title("whole run: fraction of time in spans (shaded: the window below)", fontsize=9)
        axes[1].set_title(f"{w1 - w0:.0f} ms from the middle of the run: each span", fontsize=9)
        windows = [(t0, t1), (w0, w1)]
    else:
        windows = [(t0, t1)]
    bars_ax, (b0, b1) = axes[-1], windows[-1]
    px = (b1 - b0) / _WIDTH_PX
    for y, ((_, a), c) in enumerate(zip(rows, colors, strict=True)):
        sel = a[(a[:, 0] + a[:, 1] >= b0) & (a[:, 0] <= b1)] if len(a) else a
        merged = _merge(sel, px)
        if merged:
            bars_ax.broken_barh(merged, (y - 0.4, 0.8), facecolors=c, linewidth=0)
    for ax, (x0, x1) in zip(axes, windows, strict=True):
        ax.set_yticks(range(len(rows)), [label for label, _ in rows], fontsize=8)
        ax.set_ylim(n - 0.5, -0.5)  # first row on top
        ax.set_xlim(x0, x1)
        ax.grid(axis="x", alpha=0.3)
    axes[-1].set_xlabel("time since the trace start (ms)")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    out = Path(png_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)
    return out
