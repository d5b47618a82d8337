"""Camera streams through RIO versus read directly (`python bench/cameras.py [--seconds 10] [--json]`).

Three emulated RealSense D435 (rio-realsense's software device: 640x480 RGB + aligned depth at 30 fps,
frames made and timestamped by the SDK's own software sensor) are read two ways in the same run:

- `direct`: the driver in this process without any middleware (`rio.testing.lifecycle`), its
  `read_state()` polled by one thread: what a script reading the cameras itself gets;
- `rio`: the same three drivers as nodes of a station over `--middleware` (shm by default: each camera
  its own process, frames in shared memory), read by a client polling `get_state()` as the control
  loop does.

Per way: the frame age at the reader (`now - t_frame`, the frame's capture time mapped onto rio.clock)
p50/p99, frames seen of those the cameras made (dropped = made - seen), and the CPU time of this process
and its live children (the node processes) per second of run. The ratio line is rio / direct (1.0: RIO
adds nothing). Timing on a loaded machine is noisy: compare the two ways of one run, not runs of
different machines.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from typing import Any

import numpy as np

CAMERAS, WIDTH, HEIGHT, FPS = 3, 640, 480, 30.0


def _fields(i: int) -> dict[str, Any]:
    return {"driver": "realsense.d400", "source": "software", "serial": f"10000000000{i}", "depth": True,
            "width": WIDTH, "height": HEIGHT, "rate_hz": FPS}


def _cpu_s() -> float:
    """CPU seconds of this process and its live children (the station's node processes)."""
    import psutil

    me = psutil.Process()
    total = sum(me.cpu_times()[:2])
    for child in me.children(recursive=True):
        try:
            total += sum(child.cpu_times()[:2])
        except psutil.NoSuchProcess:
            pass
    return total


def _poll(read: Any, seconds: float, poll_hz: float = 200.0) -> dict[str, Any]:
    """Poll `read(i) -> sample or None` for every camera for `seconds`; ages of new frames, frames seen."""
    from rio import clock

    ages: list[float] = []
    seen: list[set[int]] = [set() for _ in range(CAMERAS)]
    first: list[int | None] = [None] * CAMERAS
    last: list[int] = [0] * CAMERAS
    t_end, period = clock.now() + seconds, 1.0 / poll_hz
    cpu0, t0 = _cpu_s(), time.monotonic()
    while clock.now() < t_end:
        for i in range(CAMERAS):
            s = read(i)
            if s is None:
                continue
            n = int(s["frame_number"])
            if n in seen[i]:
                continue
            seen[i].add(n)
            ages.append(clock.now() - float(s["t_frame"]))
            first[i] = n if first[i] is None else first[i]
            last[i] = n
        clock.precise_wait(clock.now() + period)
    elapsed = time.monotonic() - t0
    made = sum(last[i] - first[i] + 1 for i in range(CAMERAS) if first[i] is not None)
    got = sum(len(s) for s in seen)
    a = np.asarray(ages) * 1e3
    return {"age_ms_p50": float(np.percentile(a, 50)) if a.size else float("nan"),
            "age_ms_p99": float(np.percentile(a, 99)) if a.size else float("nan"),
            "frames_seen": got, "frames_dropped": made - got,
            "fps_per_camera": got / CAMERAS / elapsed, "cpu_s_per_s": (_cpu_s() - cpu0) / elapsed}


def run_direct(seconds: float) -> dict[str, Any]:
    from contextlib import ExitStack

    from rio_realsense.driver import RealSenseCamera

    from rio.testing import lifecycle

    with ExitStack() as stack:
        nodes = []
        for i in range(CAMERAS):
            f = _fields(i)
            f.pop("driver")
            node = RealSenseCamera(**f)
            node.name = f"cam{i}"
            nodes.append(stack.enter_context(lifecycle(node)))
        return _poll(lambda i: nodes[i].read_state(), seconds)


def run_rio(seconds: float, middleware: str) -> dict[str, Any]:
    from contextlib import ExitStack

    from rio.runtime.manager import ServerManager
    from rio.station import make_station, parse_station

    station = parse_station({"name": "bench-cams", "rate_hz": 30, "middleware": {"name": middleware},
                             "components": {f"cam{i}_camera": _fields(i) for i in range(CAMERAS)}})
    servers, clients, _ = make_station(station)
    with ServerManager(servers), ExitStack() as stack:
        cams = [stack.enter_context(clients[f"cam{i}_camera"]()) for i in range(CAMERAS)]
        time.sleep(1.0)  # every camera streaming
        last: list[float] = [-1.0] * CAMERAS

        def read(i: int) -> dict[str, Any] | None:
            s = cams[i].get_state()
            if s is None or float(s["t_frame"]) == last[i]:
                return None
            last[i] = float(s["t_frame"])
            return s

        return _poll(read, seconds)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--middleware", default="shm")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    args = p.parse_args(argv)
    os.environ.setdefault("RIO_LOG_LEVEL", "WARNING")
    print(f"direct: {CAMERAS} x {WIDTH}x{HEIGHT} RGB + depth at {FPS:g} fps for {args.seconds:g} s ...",
          file=sys.stderr)
    direct = run_direct(args.seconds)
    print(f"rio over {args.middleware} ...", file=sys.stderr)
    rio = run_rio(args.seconds, args.middleware)
    ratio = {k: (rio[k] / direct[k] if direct[k] else float("nan"))
             for k in ("age_ms_p50", "age_ms_p99", "cpu_s_per_s")}
    out = {"direct": direct, "rio": rio, "ratio_rio_over_direct": ratio, "middleware": args.middleware}
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        for name, r in (("direct", direct), (f"rio ({args.middleware})", rio)):
            print(f"{name:14s} " + "  ".join(f"{k}={v:.3g}" for k, v in r.items()))
        print(f"{'ratio rio/direct':14s} " + "  ".join(f"{k}={v:.3g}" for k, v in ratio.items()))
    return 0


if __name__ == "__main__":  # spawned children re-import this file as __mp_main__: run nothing then
    raise SystemExit(main())
