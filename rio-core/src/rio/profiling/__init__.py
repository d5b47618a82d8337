"""Profiling a deployment: where each process spends its time, and what it costs in CPU, RAM and GPU.

A robot loop that misses its period rarely says why; the answer is usually in another process (a
camera node copying frames, a policy node inferring, the loop itself waiting). This package records
spans on named tracks in every process, on the one station clock, and merges them into a single trace,
so the loop and every node appear on one time axis (the RIO paper's Fig. 6), alongside a per-process
resource table (its Table III).

Use:

    with Profile("out/profile") as prof:          # before the ServerManager: its nodes inherit it
        with ServerManager(...) as mgr:
            prof.watch_nodes(mgr.pids())          # node processes in the stats table
            with prof.trace.phase("loop", "step"):
                ...

writes out/profile/trace.json, timeline.png, stats.txt and stats.json. Open trace.json at
https://ui.perfetto.dev (drag the file in) or chrome://tracing. Node runners record their
`read_state` and `handle_request` calls by themselves whenever `enable()` is in effect.
Plotting and sampling need `pip install 'rio-core[profile]'`; tracing needs nothing extra.
"""

from __future__ import annotations

from rio.profiling.session import PROFILE_ENV, Profile, active_dir, disable, enable
from rio.profiling.stats import ProcessSampler, children_of
from rio.profiling.timeline import write_timeline
from rio.profiling.trace import Trace, load_trace, merge_parts

__all__ = [
    "PROFILE_ENV", "Profile", "ProcessSampler", "Trace", "active_dir", "children_of", "disable", "enable",
    "load_trace", "merge_parts", "write_timeline",
]
