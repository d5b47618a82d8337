"""Smoke tests of the middleware latency benchmark: tiny counts on the thread middleware.

They check that it runs and the shape of what it prints, never the timings themselves.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rio.benchmarks.middleware_latency import IMAGE_KEYS, RESULT_KEYS, main, summarize

TINY = ["--n", "30", "--warmup", "5", "--image-seconds", "0.3"]


def _is_number(x: object) -> bool:
    return isinstance(x, float) and math.isfinite(x)


def test_json_shape_on_thread(capsys):
    rc = main(["--json", "--middlewares", "thread", *TINY])
    out = capsys.readouterr().out
    assert rc == 0
    result = json.loads(out)
    assert set(result) == {"thread", "images"}
    assert set(result["thread"]) == set(RESULT_KEYS)
    assert all(_is_number(v) for v in result["thread"].values()), result
    assert set(result["images"]) == {"thread"}
    assert set(result["images"]["thread"]) == set(IMAGE_KEYS)
    assert all(_is_number(v) for v in result["images"]["thread"].values()), result


def test_unknown_middleware_is_skipped_with_reason(capsys):
    rc = main(["--json", "--no-images", "--middlewares", "thread,no-such-middleware", *TINY])
    captured = capsys.readouterr()
    assert rc == 0
    result = json.loads(captured.out)
    assert set(result) == {"thread"}  # no "images" key with --no-images
    assert "no-such-middleware: skipped" in captured.err


def test_nothing_measured_exits_non_zero(capsys):
    assert main(["--json", "--no-images", "--middlewares", "no-such-middleware", *TINY]) == 1
    assert json.loads(capsys.readouterr().out) == {}


def test_table_mode(capsys):
    assert main(["--middlewares", "thread", *TINY]) == 0
    out = capsys.readouterr().out
    assert "thread" in out and "987.7" in out and "image stream" in out


def test_wrapper_script_prints_exactly_one_json_object():
    script = Path(__file__).resolve().parents[2] / "bench" / "middleware_latency.py"
    proc = subprocess.run(
        [sys.executable, str(script), "--json", "--no-images", "--middlewares", "thread", *TINY],
        capture_output=True, text=True, timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert len(proc.stdout.strip().splitlines()) == 1
    assert set(json.loads(proc.stdout)) == {"thread"}
    assert "[rio bench] thread" in proc.stderr


def test_summarize_is_one_way_and_trims_percentiles():
    rtts = np.arange(1, 101, dtype=np.float64) * 2e-6  # one-way 1..100 us
    s = summarize(rtts)
    assert set(s) == {"half_rtt_us", "mean_us", "std_us", "p99_us"}
    assert s["half_rtt_us"] == np.median(np.arange(1, 101))
    assert s["p99_us"] == np.percentile(np.arange(1, 101), 99.0)
    kept = np.arange(2, 100)  # 1 is below the 1st percentile, 100 above the 99th
    assert math.isclose(s["mean_us"], kept.mean()) and math.isclose(s["std_us"], kept.std())


@pytest.mark.slow
def test_loop_jitter_runs_every_setup_and_repeat():
    """The control-loop jitter benchmark, tiny: every setup and variant is there, each with one p99 per
    repeat and the median of them reported (the timings themselves are not checked)."""
    script = Path(__file__).resolve().parents[2] / "bench" / "loop_jitter.py"
    proc = subprocess.run([sys.executable, str(script), "--json", "--seconds", "0.2", "--repeats", "2"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert set(out["results"]) == {"thread 500 Hz", "shm 500 Hz", "shm 50 Hz, 3 cameras 640x480"}
    for variants in out["results"].values():
        assert {"sleep", "rio"} <= set(variants)
        for r in variants.values():
            assert len(r["p99_us_runs"]) == 2 and abs(r["p99_us"] - float(np.median(r["p99_us_runs"]))) <= 0.06
            assert r["ticks"] > 0 and r["max_us"] >= r["p99_us"]
    assert set(out["meets_target"]) == {"thread 500 Hz", "shm 500 Hz"}
