"""Middleware latency benchmark (`rio bench middleware`, or `python bench/middleware_latency.py`).

Method (the RIO paper's, after the Open Messaging Benchmark): a 2048-byte payload
(`np.zeros(2048, np.uint8)`), a warm-up, then `--n` timed round trips (>= 1000 for the method;
default 2000). The node API and its raw transport are measured in `--rounds` alternating blocks
(default 3), so both see the same machine conditions; statistics pool every round's samples.
One-way latency = RTT / 2. Reported, all one-way, in microseconds:

- `half_rtt_us`: median RTT / 2 of the full node API call `client.echo(payload)` (EchoNode served
  by ServerManager, client from `connect`), which is the headline figure;
- `mean_us` ± `std_us`: mean and standard deviation of RTT / 2 after dropping samples below the
  1st and above the 99th percentile;
- `p99_us`: the 99th percentile of RTT / 2;
- `raw_half_rtt_us`: median RTT / 2 of the bare transport the middleware is built on, with the same
  payload and the same timing loop, in the same run (`rio.benchmarks.raw_transports`);
- `ratio`: `half_rtt_us / raw_half_rtt_us`, the overhead the node API adds over its transport
  (the table also shows the range of the per-round ratios).

The image section serves ImageNode (640x480x3 uint8 frames) at `--image-rate` Hz for
`--image-seconds`; the client polls `get_state()` and counts distinct `frame` values per second
(`fps`); a frame's latency is the time the client first sees it minus the frame's `timestamp`
(both `rio.clock.now()`, one monotonic clock system-wide), so it includes up to one poll interval.

A middleware whose plugin fails to import or whose node fails to start is skipped, with the reason
on stderr. `--json` prints exactly one JSON object on stdout; progress always goes to stderr.
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import json
import os
import sys
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

#: The RIO paper's one-way latencies (mean, microseconds) for a 2048-byte payload, by our middleware
#: name; the paper's ZeroRpc is compared with our zmq middleware.
PAPER_US: dict[str, tuple[str, float]] = {
    "zenoh": ("Zenoh", 428.7),
    "shm": ("Shared Memory", 541.3),
    "thread": ("Thread", 987.7),
    "zmq": ("ZeroRpc", 1047.6),
    "portal": ("Portal", 1969.9),
}

RESULT_KEYS = ("half_rtt_us", "raw_half_rtt_us", "ratio", "p99_us", "mean_us", "std_us")
IMAGE_KEYS = ("fps", "latency_ms_p50", "latency_ms_p99")


def _progress(msg: str) -> None:
    print(f"[rio bench] {msg}", file=sys.stderr, flush=True)


# -- timing and statistics -------------------------------------------------------------------------
def time_roundtrips(roundtrip: Callable[[np.ndarray], Any], payload: np.ndarray, n: int,
                    warmup: int) -> np.ndarray:
    """Warm up, then time `n` calls of `roundtrip(payload)`; RTTs in seconds. The first reply is
    checked against the payload, so a transport that does not really echo cannot look fast."""
    reply = roundtrip(payload)
    got = np.asarray(reply)
    if got.shape != payload.shape or not np.array_equal(got, payload):
        raise RuntimeError(f"echo returned something else than the payload: {type(reply).__name__} "
                           f"shape {getattr(got, 'shape', '?')}")
    for _ in range(max(warmup - 1, 0)):
        roundtrip(payload)
    rtts = np.empty(n, np.float64)
    clock = time.perf_counter
    gc.collect()
    gc_was_enabled = gc.isenabled()
    gc.disable()  # a collection inside one call would land on whichever side it happens to hit
    try:
        for i in range(n):
            t0 = clock()
            roundtrip(payload)
            rtts[i] = clock() - t0
    finally:
        if gc_was_enabled:
            gc.enable()
    return rtts


def summarize(rtts_s: np.ndarray) -> dict[str, float]:
    """One-way (RTT / 2) statistics in microseconds."""
    one_way = np.asarray(rtts_s, np.float64) / 2.0 * 1e6
    lo, hi = np.percentile(one_way, [1.0, 99.0])
    kept = one_way[(one_way >= lo) & (one_way <= hi)]
    if kept.size == 0:  # tiny samples
        kept = one_way
    return {
        "half_rtt_us": float(np.median(one_way)),
        "mean_us": float(kept.mean()),
        "std_us": float(kept.std()),
        "p99_us": float(hi),
    }


# -- one middleware --------------------------------------------------------------------------------
@contextlib.contextmanager
def _keep_start_method() -> Iterator[None]:
    from rio.benchmarks.raw_transports import keep_start_method

    with keep_start_method():
        yield


RoundTrip = Callable[[np.ndarray], Any]


@contextlib.contextmanager
def node_roundtrip(mw: str, station: str, payload: np.ndarray) -> Iterator[RoundTrip]:
    """`client.echo` of an EchoNode served on `mw` by a ServerManager."""
    from rio.runtime.manager import ServerManager, connect, serve
    from rio.testing import EchoNode

    cfg: dict[str, Any] = {"payload_bytes": int(payload.nbytes)}
    with ServerManager(mw, [serve(EchoNode, name="echo", **cfg)], station=station, ready_timeout=60.0):
        with connect(EchoNode, mw, name="echo", station=station, **cfg) as client:
            yield client.echo


def raw_roundtrip(mw: str, payload: np.ndarray) -> contextlib.AbstractContextManager[RoundTrip]:
    from rio.benchmarks.raw_transports import RAW

    return RAW[mw].open(payload)


def interleaved_rtts(node: RoundTrip, raw: RoundTrip | None, payload: np.ndarray, n: int, warmup: int,
                     rounds: int) -> tuple[np.ndarray, np.ndarray | None, list[float]]:
    """`rounds` alternating blocks of `n` round trips on the node API, then the raw transport.
    Alternating puts both under the same machine conditions: here the same raw test swings 2-5x
    between minutes, and where the scheduler places the two processes (one core or two) changes a
    wake-up's cost ~8x. Returns all node RTTs, all raw RTTs (or None), and each round's ratio of
    medians."""
    node_all, raw_all, ratios = [], [], []
    for _ in range(rounds):
        node_rtts = time_roundtrips(node, payload, n, warmup)
        node_all.append(node_rtts)
        if raw is not None:
            raw_rtts = time_roundtrips(raw, payload, n, warmup)
            raw_all.append(raw_rtts)
            ratios.append(float(np.median(node_rtts) / np.median(raw_rtts)))
    return np.concatenate(node_all), (np.concatenate(raw_all) if raw_all else None), ratios


def image_stream(mw: str, station: str, seconds: float, rate_hz: float, poll_s: float,
                 settle_s: float = 0.3) -> dict[str, float]:
    from rio import clock
    from rio.errors import NodeDiedError, RioError
    from rio.runtime.manager import ServerManager, connect, serve
    from rio.testing import ImageNode

    cfg: dict[str, Any] = {"rate_hz": float(rate_hz)}
    with ServerManager(mw, [serve(ImageNode, name="camera", **cfg)], station=station, ready_timeout=60.0):
        with connect(ImageNode, mw, name="camera", station=station, **cfg) as cam:
            deadline = clock.now() + 10.0
            while True:  # a network mirror may not hold a frame yet right after start-up
                try:
                    cam.get_state()
                    break
                except NodeDiedError:
                    raise
                except RioError:
                    if clock.now() > deadline:
                        raise
                    time.sleep(0.01)
            last = -1
            t_settle = clock.now() + settle_s
            while clock.now() < t_settle:
                last = int(cam.get_state()["frame"])
                time.sleep(poll_s)
            latencies: list[float] = []
            t_start = clock.now()
            t_end = t_start + seconds
            while True:
                state = cam.get_state()
                t_seen = clock.now()
                frame = int(state["frame"])
                if frame != last:
                    last = frame
                    latencies.append(t_seen - float(state["timestamp"]))
                if t_seen >= t_end:
                    break
                time.sleep(poll_s)
            elapsed = clock.now() - t_start
    lat_ms = np.asarray(latencies) * 1e3
    if lat_ms.size == 0:
        raise RuntimeError(f"no new frame in {seconds:.1f} s")
    return {
        "fps": len(latencies) / elapsed,
        "latency_ms_p50": float(np.median(lat_ms)),
        "latency_ms_p99": float(np.percentile(lat_ms, 99.0)),
    }


def _reason(e: BaseException) -> str:
    text = f"{type(e).__name__}: {e}".strip()
    first = text.splitlines()[0] if text else type(e).__name__
    return first if len(first) <= 300 else first[:297] + "..."


def _failure(e: BaseException) -> str:
    """Why a step failed, for the report. A failing middleware is skipped, but Ctrl+C still stops."""
    if isinstance(e, KeyboardInterrupt):
        raise e
    return _reason(e)


def _skip(details: dict[str, Any], name: str, why: str) -> None:
    details["skipped"][name] = why
    _progress(f"{name}: skipped ({why})")


# -- command line ----------------------------------------------------------------------------------
def registered_middlewares() -> list[str]:
    try:
        from rio.plugins import get_registry

        return [s.name for s in get_registry().specs("rio_middlewares")]
    except Exception as e:  # a broken third-party plugin must not hide the built-in ones
        _progress(f"could not list registered middlewares ({_reason(e)}); using the built-in names")
        from rio.benchmarks.raw_transports import RAW

        return list(RAW)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="rio bench middleware",
        description="One-way latency of the node API (client.echo) on each middleware, against the raw "
                    "transport underneath it, plus an image-stream test.",
    )
    p.add_argument("--middlewares", "-m", default=None,
                   help="comma-separated names (default: every registered middleware)")
    p.add_argument("--n", type=int, default=2000, help="timed round trips per measurement (default 2000)")
    p.add_argument("--warmup", type=int, default=200, help="untimed round trips first (default 200)")
    p.add_argument("--rounds", type=int, default=3,
                   help="alternating node/raw measurement rounds, --n round trips each (default 3)")
    p.add_argument("--payload-bytes", type=int, default=2048, help="payload size (default 2048)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    p.add_argument("--images", action=argparse.BooleanOptionalAction, default=True,
                   help="run the image-stream test (default on)")
    p.add_argument("--image-seconds", type=float, default=3.0, help="image-stream duration (default 3 s)")
    p.add_argument("--image-rate", type=float, default=200.0, help="ImageNode publishing rate (default 200 Hz)")
    p.add_argument("--image-poll-ms", type=float, default=0.2,
                   help="client sleep between get_state() polls (default 0.2 ms)")
    return p


@contextlib.contextmanager
def _stdout_to_stderr() -> Iterator[None]:
    """Keep stdout clean for the result: anything a library or a child process prints while we
    measure goes to stderr (file descriptor 1 too, which spawned children inherit)."""
    out = sys.stdout
    saved_fd: int | None = None
    fd = -1
    try:
        out.flush()
        sys.stderr.flush()
        fd, err_fd = out.fileno(), sys.stderr.fileno()
        saved_fd = os.dup(fd)
        os.dup2(err_fd, fd)
    except (AttributeError, OSError, ValueError):  # not a real file (pytest capture, IDE consoles)
        saved_fd = None
    sys.stdout = sys.stderr
    try:
        yield
    finally:
        sys.stderr.flush()
        sys.stdout = out
        if saved_fd is not None:
            os.dup2(saved_fd, fd)
            os.close(saved_fd)


def run(args: argparse.Namespace) -> tuple[dict[str, Any], dict[str, Any]]:
    """Measure; returns (results for JSON, extra details for the table)."""
    from rio.benchmarks.raw_transports import RAW

    names = ([m.strip() for m in args.middlewares.split(",") if m.strip()] if args.middlewares
             else registered_middlewares())
    payload = np.zeros(args.payload_bytes, np.uint8)
    station = f"bench{os.getpid()}"
    results: dict[str, Any] = {}
    images: dict[str, Any] = {}
    details: dict[str, Any] = {"skipped": {}, "raw": {}, "images_skipped": {}, "round_ratios": {}}
    poll_s = max(args.image_poll_ms, 0.0) / 1e3

    for name in names:
        t0 = time.monotonic()
        with _keep_start_method():
            try:
                from rio.plugins import get_middleware

                get_middleware(name)
            except BaseException as e:
                _skip(details, name, f"did not import: {_failure(e)}")
                continue
            _progress(f"{name}: node API client.echo() and the raw transport, {args.rounds} alternating "
                      f"rounds of {args.warmup} warm-up + {args.n} round trips ...")
            with contextlib.ExitStack() as stack:
                try:
                    node_rt = stack.enter_context(node_roundtrip(name, station, payload))
                except BaseException as e:
                    _skip(details, name, f"node API failed: {_failure(e)}")
                    continue
                raw_rt = None
                if name not in RAW:
                    details["raw"][name] = {"error": "no raw transport known for this middleware"}
                else:
                    try:
                        raw_rt = stack.enter_context(raw_roundtrip(name, payload))
                    except BaseException as e:
                        details["raw"][name] = {"error": _failure(e)}
                        _progress(f"{name}: raw transport failed ({details['raw'][name]['error']}); ratio left out")
                try:
                    node_rtts, raw_rtts, ratios = interleaved_rtts(node_rt, raw_rt, payload, args.n,
                                                                   args.warmup, args.rounds)
                except BaseException as e:
                    _skip(details, name, f"measurement failed: {_failure(e)}")
                    continue
            node = summarize(node_rtts)
            raw = summarize(raw_rtts) if raw_rtts is not None else None
            if raw is not None:
                details["raw"][name] = raw
                details["round_ratios"][name] = ratios
            results[name] = {
                "half_rtt_us": node["half_rtt_us"],
                "raw_half_rtt_us": raw["half_rtt_us"] if raw else None,
                "ratio": node["half_rtt_us"] / raw["half_rtt_us"] if raw and raw["half_rtt_us"] > 0 else None,
                "p99_us": node["p99_us"],
                "mean_us": node["mean_us"],
                "std_us": node["std_us"],
            }
            if args.images:
                _progress(f"{name}: image stream, ImageNode at {args.image_rate:g} Hz for {args.image_seconds:g} s ...")
                try:
                    images[name] = image_stream(name, station, args.image_seconds, args.image_rate, poll_s)
                except BaseException as e:
                    details["images_skipped"][name] = _failure(e)
                    _progress(f"{name}: image stream failed ({details['images_skipped'][name]})")
        _progress(f"{name}: done in {time.monotonic() - t0:.1f} s")

    if args.images:
        results["images"] = images
    return results, details


def _fmt(x: float | None, spec: str = ".1f") -> str:
    return "-" if x is None else format(x, spec)


def format_table(results: dict[str, Any], details: dict[str, Any], args: argparse.Namespace) -> str:
    from rio.benchmarks.raw_transports import RAW

    lines = [
        f"RIO middleware latency: {args.payload_bytes}-byte payload, {args.rounds} alternating node/raw rounds of "
        f"{args.warmup} warm-up + {args.n} timed round trips; one-way latency = RTT/2, microseconds",
        "  node = client.echo(payload) through ServerManager + connect; raw = the bare transport underneath;",
        "  mean ± std after dropping the 1st and 99th percentiles; paper = the RIO paper's one-way mean",
    ]
    if args.n < 1000:
        lines.append(f"  (n={args.n} is below the method's 1000 round trips: a smoke run, not a measurement)")
    lines.append("")
    head = (f"{'middleware':<11}{'node p50':>10}{'raw p50':>10}{'ratio':>8}{'rounds':>12}{'node mean ± std':>20}"
            f"{'p99':>10}   {'paper mean':<22}{'speed-up':>9}")
    lines += [head, "-" * len(head)]
    for name, r in results.items():
        if name == "images":
            continue
        paper = PAPER_US.get(name)
        paper_s = f"{paper[1]:.1f} ({paper[0]})" if paper else "-"
        speed = f"{paper[1] / r['mean_us']:.1f}x" if paper and r["mean_us"] > 0 else "-"
        ms = f"{r['mean_us']:.1f} ± {r['std_us']:.1f}"
        rr = details["round_ratios"].get(name)
        rounds = f"{min(rr):.2f}-{max(rr):.2f}" if rr else "-"
        lines.append(f"{name:<11}{_fmt(r['half_rtt_us']):>10}{_fmt(r['raw_half_rtt_us']):>10}"
                     f"{_fmt(r['ratio'], '.2f'):>8}{rounds:>12}{ms:>20}{_fmt(r['p99_us']):>10}   "
                     f"{paper_s:<22}{speed:>9}")
    lines.append("")
    lines.append("raw transports:")
    for name in results:
        if name == "images":
            continue
        raw = details["raw"].get(name, {})
        desc = RAW[name].description if name in RAW else "-"
        extra = f" [failed: {raw['error']}]" if "error" in raw else ""
        lines.append(f"  {name:<8} {desc}{extra}")
    if "thread" in results:
        lines.append("  (thread: the node API is a direct call in the caller's thread under the node's lock; "
                     "the raw figure includes two thread switches, so its ratio can be below 1)")
    if "images" in results:
        lines += ["", f"image stream: ImageNode 640x480x3 uint8 at {args.image_rate:g} Hz for "
                  f"{args.image_seconds:g} s; client polls get_state() every ~{args.image_poll_ms:g} ms; "
                  "latency = first seen - frame timestamp"]
        ih = f"{'middleware':<11}{'fps':>8}{'latency p50 (ms)':>19}{'p99 (ms)':>10}"
        lines += [ih, "-" * len(ih)]
        for name, r in results["images"].items():
            lines.append(f"{name:<11}{r['fps']:>8.1f}{r['latency_ms_p50']:>19.2f}{r['latency_ms_p99']:>10.2f}")
        for name, why in details["images_skipped"].items():
            lines.append(f"{name:<11}  failed: {why}")
    if details["skipped"]:
        lines += ["", "skipped:"]
        lines += [f"  {name}: {why}" for name, why in details["skipped"].items()]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.n < 1 or args.warmup < 0 or args.payload_bytes < 1 or args.rounds < 1:
        print("rio bench middleware: --n, --rounds and --payload-bytes must be >= 1, --warmup >= 0",
              file=sys.stderr)
        return 2
    t0 = time.monotonic()
    with _stdout_to_stderr():
        results, details = run(args)
    _progress(f"finished in {time.monotonic() - t0:.1f} s")
    if args.json:
        print(json.dumps(results))
    else:
        print(format_table(results, details, args))
    sys.stdout.flush()
    return 0 if any(k != "images" for k in results) else 1


if __name__ == "__main__":
    raise SystemExit(main())
