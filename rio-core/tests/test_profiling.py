"""rio.profiling: traces that Chrome/Perfetto load, part files from node threads and node processes,
per-process CPU/RAM sampling, the timeline PNG, and `Profile` tying them together."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import threading
import time

import pytest

import rio.profiling as prof
from rio import ServerManager, clock, connect, serve
from rio.profiling import ProcessSampler, Profile, Trace, load_trace, merge_parts, write_timeline
from rio.profiling.timeline import _rows
from rio.profiling.trace import read_part
from rio.testing import Counter, EchoNode, wait_until

REQUIRED = ("ph", "ts", "pid", "tid", "name")


@pytest.fixture(autouse=True)
def _profiling_off():
    prof.disable()
    yield
    prof.disable()




def _names(trace, what):
    """{pid: name} for process_name, {(pid, tid): name} for thread_name metadata."""
    out = {}
    for ev in trace["traceEvents"]:
        if ev["ph"] == "M" and ev["name"] == what:
            out[ev["pid"] if what == "process_name" else (ev["pid"], ev["tid"])] = ev["args"]["name"]
    return out


def _spans(trace, process, track):
    pids = {pid for pid, name in _names(trace, "process_name").items() if name == process}
    tids = {k for k, name in _names(trace, "thread_name").items() if name == track and k[0] in pids}
    return [ev for ev in trace["traceEvents"] if ev["ph"] == "X" and (ev["pid"], ev["tid"]) in tids]


def _part(directory, process):
    """The one part file of `process` in `directory`, and its spans as (track, name, dur_s)."""
    (part,) = [p for p in map(read_part, directory.glob("*.trace.json")) if p.process == process]
    track = {tid: name for name, tid in part.tracks.items()}
    spans = [(track[part.keys[k][1]], part.keys[k][2], t1 - t0)
             for k, t0, t1 in zip(part.key, part.t0, part.t1, strict=True) if part.keys[k][0] == "X"]
    return part, spans


# -- Trace, parts, merge --------------------------------------------------------------------------------
def test_spans_and_counters_round_trip_to_a_valid_chrome_trace(tmp_path):
    tr = Trace("loop")
    t = clock.now()
    tr.span("control", "step", t, t + 0.002, cycle=1)
    tr.span("io", "read", t + 0.001, t + 0.0015)
    tr.span("control", "step", t + 0.010, t + 0.012)
    with tr.phase("control", "sleep"):
        time.sleep(0.001)
    tr.counter("loop CPU %", t + 0.005, cpu=42.0)

    def many():
        for k in range(500):
            tr.span("worker", "w", t + k * 1e-5, t + k * 1e-5 + 1e-6)

    threads = [threading.Thread(target=many) for _ in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert tr.tracks() == {"control": 1, "io": 2, "worker": 3}  # first-use order
    part = tr.write_part(tmp_path / "parts")
    assert part.name.endswith(".trace.json") and part.name.startswith("loop-")

    merged = merge_parts(tmp_path / "parts", tmp_path / "trace.json")
    doc = load_trace(tmp_path / "trace.json")
    assert doc == json.loads((tmp_path / "trace.json").read_text()) == merged
    assert doc["displayTimeUnit"] == "ms"
    for ev in doc["traceEvents"]:
        assert all(k in ev for k in REQUIRED), ev
        if ev["ph"] == "X":
            assert ev["dur"] >= 0
    assert list(_names(doc, "process_name").values()) == ["loop"]
    assert sorted(_names(doc, "thread_name").values()) == ["control", "io", "worker"]
    control = _spans(doc, "loop", "control")
    steps = [e for e in control if e["name"] == "step"]
    (sleep,) = [e for e in control if e["name"] == "sleep"]
    assert len(control) == 3
    assert steps[0]["ts"] == pytest.approx(0.0, abs=1e-3)  # the origin is the earliest event
    assert steps[0]["dur"] == pytest.approx(2000.0, rel=1e-6) and steps[0]["args"] == {"cycle": 1}
    assert steps[1]["ts"] == pytest.approx(10_000.0, rel=1e-6)
    assert sleep["dur"] >= 1000.0  # the phase timed the sleep
    assert len(_spans(doc, "loop", "worker")) == 2000
    counters = [ev for ev in doc["traceEvents"] if ev["ph"] == "C"]
    assert counters == [{"ph": "C", "name": "loop CPU %", "ts": pytest.approx(5000.0, rel=1e-6), "pid": 1,
                         "tid": 0, "args": {"cpu": 42.0}}]


def test_events_past_the_cap_are_dropped_and_reported(tmp_path):
    tr = Trace("loop", max_events=5)
    for k in range(8):
        tr.span("a", "x", k, k + 0.5)
    assert len(tr) == 5 and tr.dropped == 3
    tr.write_part(tmp_path)
    doc = merge_parts(tmp_path, tmp_path / "out" / "trace.json")
    assert doc["otherData"]["dropped_events"] == {"loop": 3}
    assert _names(doc, "process_name") == {1: "loop (dropped 3 events)"}


def test_load_trace_names_what_is_wrong(tmp_path):
    bad = tmp_path / "t.json"
    bad.write_text(json.dumps({"traceEvents": [{"ph": "X", "name": "a", "pid": 1, "tid": 1, "dur": 1}]}))
    with pytest.raises(ValueError, match=r"event 0 \('a'\) lacks \['ts'\]"):
        load_trace(bad)
    bad.write_text(json.dumps({"traceEvents": [{"ph": "X", "name": "a", "pid": 1, "tid": 1, "ts": 0, "dur": -1}]}))
    with pytest.raises(ValueError, match="non-negative 'dur'"):
        load_trace(bad)
    bad.write_text(json.dumps([]))
    with pytest.raises(ValueError, match="traceEvents"):
        load_trace(bad)
    with pytest.raises(ValueError, match="no readable trace parts"):
        merge_parts(tmp_path / "empty", tmp_path / "x.json")


def test_parts_from_two_processes_merge_into_two_groups_on_one_clock(tmp_path):
    parts = tmp_path / "parts"
    mine = Trace("loop")
    t0 = clock.now()
    code = textwrap.dedent(f"""
        from rio import clock
        from rio.profiling import Trace
        tr = Trace("worker")
        t = clock.now()
        tr.span("compute", "infer", t, t + 0.003)
        tr.write_part({str(parts)!r})
    """)
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)
    mine.span("control", "step", t0, t0 + 0.001)  # before the child's span, by the shared clock
    mine.write_part(parts)
    doc = merge_parts(parts, tmp_path / "trace.json")
    names = _names(doc, "process_name")
    assert sorted(names.values()) == ["loop", "worker"] and len(names) == 2
    assert set(doc["otherData"]["processes"].values()) >= {os.getpid()} and len(doc["otherData"]["processes"]) == 2
    (infer,), (step,) = _spans(doc, "worker", "compute"), _spans(doc, "loop", "control")
    assert infer["pid"] != step["pid"]
    assert step["ts"] == 0.0 and infer["ts"] > 0  # the child ran after t0
    assert infer["dur"] == pytest.approx(3000.0, rel=1e-6)


# -- node runners under profiling -----------------------------------------------------------------------
def test_a_thread_node_writes_read_state_spans_when_profiling_is_on(tmp_path):
    prof.enable(tmp_path)
    assert prof.active_dir() == tmp_path.resolve() and os.environ[prof.PROFILE_ENV] == str(tmp_path.resolve())
    with ServerManager("thread", [serve(Counter, name="p", rate_hz=100)]):
        with connect(Counter, "thread", name="p") as c:
            assert wait_until(lambda: c.get_state()["i"] > 10, timeout=5)
    part, spans = _part(tmp_path, "node p")
    assert len(spans) > 5 and {(track, name) for track, name, _ in spans} == {("read_state", "read_state")}
    assert all(dur >= 0 for _, _, dur in spans)
    assert part.pid == os.getpid()  # thread middleware: the node runs in this process


def test_a_node_process_writes_its_part_with_read_state_and_request_spans(tmp_path):
    prof.enable(tmp_path)
    with ServerManager("shm", [serve(EchoNode, name="echo", rate_hz=100)]):
        with connect(EchoNode, "shm", name="echo") as c:
            for seq in range(5):
                c.send_request(q=[0.0] * 6, client=1, seq=seq)
            assert wait_until(lambda: len(c.handled()) == 5, timeout=10)
            node_pid = c.pid()
    part, spans = _part(tmp_path, "node echo")
    assert part.pid == node_pid != os.getpid()
    assert set(part.tracks) == {"read_state", "request"}
    assert sum(1 for s in spans if s[:2] == ("read_state", "read_state")) > 0
    assert sum(1 for s in spans if s[:2] == ("request", "handle_request")) == 5


def test_nothing_is_recorded_once_profiling_is_disabled(tmp_path):
    prof.enable(tmp_path)
    prof.disable()
    assert prof.active_dir() is None and prof.PROFILE_ENV not in os.environ
    with ServerManager("thread", [serve(Counter, name="p", rate_hz=200)]):
        with connect(Counter, "thread", name="p") as c:
            assert wait_until(lambda: c.get_state()["i"] > 3, timeout=5)
    assert list(tmp_path.iterdir()) == []


# -- resource sampling ----------------------------------------------------------------------------------
BUSY = "import time\nt = time.process_time()\nwhile time.process_time() - t < 1.0:\n    pass\n"


def test_sampler_measures_a_busy_child_and_keeps_its_rows_after_it_exits():
    child = subprocess.Popen([sys.executable, "-c", BUSY])
    try:
        assert child.pid in prof.children_of(os.getpid()).values()
        tr = Trace("loop")
        with ProcessSampler({"loop": os.getpid()}, period_s=0.1, trace=tr) as sampler:
            sampler.add("busy", child.pid)
            child.wait(timeout=30)
            time.sleep(0.3)  # a few samples after it exited
    finally:
        child.kill()
        child.wait()
    rows = {r["label"]: r for r in sampler.rows()}
    assert set(rows) == {"loop", "busy"}
    busy, loop = rows["busy"], rows["loop"]
    assert busy["pid"] == child.pid and busy["samples"] >= 2
    assert busy["cpu_pct_max"] > 20.0, busy  # ~100 % of a core while it ran; loose: the machine is shared
    assert busy["rss_mb_max"] > 1.0 and loop["rss_mb_mean"] > 1.0
    assert loop["samples"] > busy["samples"]  # sampling it stopped when it exited; the loop went on
    if not sampler.has_gpu:
        assert busy["gpu_mem_mb_max"] is None
    table = sampler.table().splitlines()
    assert table[0].split()[:2] == ["process", "pid"]
    assert [line.split()[0] for line in table[2:4]] == ["loop", "busy"]
    assert table[-1].startswith("GPU:")
    counters = {ev["name"] for ev in tr.events() if ev["ph"] == "C"}
    assert {"loop CPU %", "busy CPU %", "busy RSS MB"} <= counters


# -- timeline -------------------------------------------------------------------------------------------
def test_timeline_png_has_a_row_per_track_and_renders_large_traces(tmp_path):
    import matplotlib.image

    parts = tmp_path / "parts"
    loop, node = Trace("loop"), Trace("node arm")
    t = clock.now()
    for k in range(30_000):  # a 1 kHz node for 30 s: more spans than pixels
        node.span("read_state", "read_state", t + k * 1e-3, t + k * 1e-3 + 2e-4)
    node.span("request", "handle_request", t + 0.5, t + 0.6)
    for k in range(100):
        loop.span("step", "step", t + k * 0.3, t + k * 0.3 + 0.01)
    loop.write_part(parts)
    node.write_part(parts)
    doc = merge_parts(parts, tmp_path / "trace.json")
    assert [label for label, _ in _rows(doc)] == ["loop / step", "node arm / read_state", "node arm / request"]

    png = write_timeline(tmp_path / "trace.json", tmp_path / "timeline.png", title="test")
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    img = matplotlib.image.imread(png)
    # two panels (whole run, and a window of single spans: 30k spans are too many to draw), three rows each
    assert abs(img.shape[0] - 150 * (2 * (0.6 + 0.35 * 3) + 0.4)) <= 1 and img.shape[1] == 16 * 150
    assert (img[..., :3].std(axis=(0, 1)) > 0).any()  # something was drawn


# -- Profile end to end ---------------------------------------------------------------------------------
def test_profile_writes_trace_timeline_and_stats_for_a_run(tmp_path):
    out = tmp_path / "profile"
    with Profile(out, period_s=0.05) as p:
        assert prof.active_dir() == (out / "parts").resolve()
        with ServerManager("thread", [serve(Counter, name="p", rate_hz=100), serve(EchoNode, name="e", rate_hz=50)]):
            with connect(Counter, "thread", name="p") as c, connect(EchoNode, "thread", name="e") as e:
                for seq in range(20):
                    with p.trace.phase("loop", "step"):
                        c.get_state()
                        e.send_request(q=[0.0] * 6, client=0, seq=seq)
                    time.sleep(0.01)
                assert wait_until(lambda: len(e.handled()) == 20, timeout=5)
    assert prof.active_dir() is None
    names = sorted(f.name for f in p.files)
    assert names == ["stats.json", "stats.txt", "timeline.png", "trace.json"]
    assert all((out / n).stat().st_size > 0 for n in names)
    doc = load_trace(out / "trace.json")
    assert sorted(_names(doc, "process_name").values()) == ["loop", "node e", "node p"]
    assert len(_spans(doc, "loop", "loop")) == 20
    assert len(_spans(doc, "node p", "read_state")) > 5
    assert len(_spans(doc, "node e", "request")) == 20
    stats = json.loads((out / "stats.json").read_text())
    assert [r["label"] for r in stats["processes"]] == ["loop"] and stats["processes"][0]["samples"] > 0
    assert (out / "stats.txt").read_text().splitlines()[2].startswith("loop")
    lines = p.summary_lines()
    assert str(out) in lines[0] and "trace.json" in lines[0] and any("perfetto" in x for x in lines)
    assert not p.warnings


def test_a_failed_png_keeps_the_trace_and_says_why(tmp_path, monkeypatch):
    import rio.profiling.timeline as timeline

    def broken(*a, **k):
        raise ImportError("the timeline PNG needs matplotlib: pip install 'rio-core[profile]'")

    monkeypatch.setattr(timeline, "write_timeline", broken)
    with Profile(tmp_path) as p:
        with p.trace.phase("loop", "step"):
            pass
    assert (tmp_path / "trace.json").exists() and not (tmp_path / "timeline.png").exists()
    assert (tmp_path / "stats.txt").exists()
    assert len(p.warnings) == 1 and "timeline.png not written" in p.warnings[0] and "rio-core[profile]" in p.warnings[0]
    assert any("warning: timeline.png" in x for x in p.summary_lines())


def test_without_psutil_a_profile_still_writes_its_trace(tmp_path, monkeypatch):
    import rio.profiling.stats as stats

    def missing():
        raise ImportError("per-process CPU/RAM sampling needs psutil: pip install 'rio-core[profile]'")

    monkeypatch.setattr(stats, "_psutil", missing)
    with Profile(tmp_path) as p:
        p.sampler.add("node x", os.getpid())  # what a workflow does; harmless here
        p.trace.span("loop", "step", clock.now(), clock.now())
    assert not p.sampler.available
    assert [f.name for f in p.files] == ["trace.json", "timeline.png"]
    assert not (tmp_path / "stats.txt").exists()
    assert any("rio-core[profile]" in w for w in p.warnings)


def test_gpu_columns_from_nvml(monkeypatch):
    """No GPU here: a stand-in pynvml with one device on which this process holds 512 MB."""
    import types

    mb = 1024 * 1024
    nv = types.SimpleNamespace(
        nvmlInit=lambda: None, nvmlShutdown=lambda: None, nvmlDeviceGetCount=lambda: 1,
        nvmlDeviceGetHandleByIndex=lambda i: f"gpu{i}", nvmlDeviceGetName=lambda h: b"NVIDIA Test",
        nvmlDeviceGetUtilizationRates=lambda h: types.SimpleNamespace(gpu=40),
        nvmlDeviceGetMemoryInfo=lambda h: types.SimpleNamespace(used=2048 * mb),
        nvmlDeviceGetComputeRunningProcesses=lambda h: [types.SimpleNamespace(pid=os.getpid(), usedGpuMemory=512 * mb)],
        nvmlDeviceGetGraphicsRunningProcesses=lambda h: [],
    )
    monkeypatch.setitem(sys.modules, "pynvml", nv)
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        sampler = ProcessSampler({"loop": os.getpid(), "other": child.pid}, period_s=60).start()  # sampled by hand
        sampler.sample()
        sampler.sample()
        sampler.stop()
    finally:
        child.kill()
        child.wait()
    rows = {r["label"]: r for r in sampler.rows()}
    assert rows["loop"]["gpu_mem_mb_max"] == pytest.approx(512.0)
    assert rows["other"]["gpu_mem_mb_max"] == 0.0  # a GPU exists; this process uses none of it
    assert sampler.gpu_summary() == {"devices": ["NVIDIA Test"], "util_pct_mean": 40.0, "util_pct_max": 40.0,
                                     "mem_used_mb_max": 2048.0, "samples": 2}
    assert sampler.table().splitlines()[-1] == (
        "GPU: NVIDIA Test: utilisation mean 40.0 %, max 40.0 %; memory in use max 2048.0 MB")


def test_a_profile_where_nothing_can_be_written_is_one_error(tmp_path):
    from rio.errors import ConfigError

    (tmp_path / "file").write_text("x")
    with pytest.raises(ConfigError, match=r"file/prof: cannot write the profile here \(Not a directory\)"), \
            Profile(tmp_path / "file" / "prof"):
        pass
