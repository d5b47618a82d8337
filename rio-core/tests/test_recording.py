"""Recorder + native format: values read back exactly, timestamps consistent with the declared
fps, fast episode close, keep/discard/re-record bookkeeping, one writer per dataset, replay."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from rio import clock
from rio.recording import Dataset, Recorder, RecordingError
from rio.recording.synthetic import SyntheticCamera, record_synthetic, synthetic_step


def test_round_trip_exact_state_and_close_fast(tmp_path):
    cam = SyntheticCamera(48, 64, noise=1.0)
    sent = []
    with Recorder(tmp_path / "ds", fps=50, video={"crf": 18}) as rec:
        rate = clock.Rate(50)
        for i in range(40):
            t = clock.now()
            step = synthetic_step(i, t, {"front": (cam.frame(t), t)})
            step.observation.cameras["front"].depth = cam.depth(t)
            sent.append(step)
            rec.add(step)
            rate.sleep()
        meta = rec.keep()
        assert rec.last_close_s < 10.0  # a close that waits out a timeout, not speed (2.7 s seen at load 13)
    ep = Dataset(tmp_path / "ds").episode(0)
    assert len(ep) == 40 and ep.verify() == []
    np.testing.assert_array_equal(ep.column("action"), np.stack([s.action for s in sent]))
    np.testing.assert_array_equal(ep.column("obs.proprio_eef"), np.stack([s.observation.proprio_eef for s in sent]))
    assert ep.column("obs.gripper_width").dtype == np.float64
    # timestamps: from rio.clock.now(), increasing, at the declared rate
    t = ep.column("t")
    assert np.all(np.diff(t) > 0)
    assert meta["fps"] == 50 and abs(meta["measured_fps"] - 39 / (t[-1] - t[0])) < 1e-3
    assert abs(meta["measured_fps"] - 50) < 5  # a loaded 2-core CI box may lose a few ticks
    assert np.allclose(t, [s.meta["t_obs"] for s in sent])
    # camera: every step saw a new frame; frames within codec tolerance, depth lossless (1 mm)
    frames = list(ep.step_frames("front"))
    assert len(frames) == 40
    err = np.mean([np.abs(f.astype(int) - s.observation.cameras["front"].rgb.astype(int)).mean()
                   for f, s in zip(frames, sent, strict=False)])
    assert err < 6, err  # mean absolute error in grey levels (CRF 18, 4:2:0 chroma on a tiny frame)
    depth = ep.depth_m(next(iter(ep.step_frames("front", "depth"))), "front")
    np.testing.assert_allclose(depth, sent[0].observation.cameras["front"].depth, atol=1e-6)
    steps = list(ep.steps())
    assert type(steps[0].observation).__name__ == "SingleArmObs" and steps[5].instruction == "pick up the cube"
    assert steps[3].timestep == 3 and steps[3].observation.cameras["front"].rgb.shape == (48, 64, 3)


def test_camera_slower_than_loop_is_not_duplicated(tmp_path):
    """A 25 fps camera in a 100 Hz loop: frames are encoded once, steps point at the frame they saw."""
    cam = SyntheticCamera(32, 32, noise=0)
    with Recorder(tmp_path / "ds", fps=100) as rec:
        t0 = clock.now()
        for i in range(100):
            t = t0 + i / 100
            tc = t0 + (i // 4) / 25
            rec.add(synthetic_step(i, t, {"front": (cam.frame(tc), tc)}))
        meta = rec.keep()
    s = meta["streams"]["front.rgb"]
    assert s["frames"] == 25 and s["rate"] == 25.0
    ep = Dataset(tmp_path / "ds").episode(0)
    assert list(ep.step_frame_index("front")[:9]) == [0, 0, 0, 0, 1, 1, 1, 1, 2]
    assert ep.frame_times("front")["step"][:3].tolist() == [0, 4, 8]


def test_keep_discard_rerecord_and_episode_budget(tmp_path):
    root = tmp_path / "ds"
    with Recorder(root, fps=30, episodes=2) as rec:
        for i in range(5):
            rec.add(synthetic_step(i, clock.now()))
        rec.discard()
        for i in range(5):
            rec.add(synthetic_step(i, clock.now()))
        rec.rerecord()
        assert not rec.recording and rec.remaining == 2
        for _ in range(2):
            for i in range(5):
                rec.add(synthetic_step(i, clock.now()))
            rec.keep()
        assert rec.done and rec.remaining == 0
        with pytest.raises(RecordingError):
            rec.start_episode()
    ds = Dataset(root)
    assert [e["index"] for e in ds.episodes] == [0, 1]  # kept episodes stay contiguous: discarded numbers reused
    assert ds.summary()["discarded"] == 2
    index = json.loads((root / "dataset.json").read_text())
    assert index["total_steps"] == 10


def test_exit_keeps_episode_in_progress_and_lock_is_exclusive(tmp_path):
    root = tmp_path / "ds"
    with Recorder(root, fps=30) as rec:
        rec.add(synthetic_step(0, clock.now()))
        with pytest.raises(RecordingError, match="another recorder"):
            Recorder(root, fps=30).open()
    assert len(Dataset(root)) == 1
    with Recorder(root, fps=30) as rec:  # appends after what is there
        rec.add(synthetic_step(0, clock.now()))
    assert [e["index"] for e in Dataset(root).episodes] == [0, 1]


def test_record_synthetic_helper_and_info(tmp_path):
    metas = record_synthetic(str(tmp_path / "ds"), episodes=2, steps=10)
    assert [m["length"] for m in metas] == [10, 10]
    s = Dataset(tmp_path / "ds").summary()
    assert s["streams"] == ["front.depth", "front.rgb", "wrist.rgb"] and s["steps"] == 20


def test_a_station_with_cameras_is_not_recorded_without_its_encoder(tmp_path, monkeypatch):
    """Without PyAV (its import made to fail) a recording with cameras refuses to start, naming the fix,
    instead of keeping episodes without their video; one without cameras still records."""
    import sys

    monkeypatch.setitem(sys.modules, "av", None)  # `import av` raises ImportError
    with pytest.raises(RecordingError, match="needs PyAV: pip install"):
        Recorder(tmp_path / "cams", fps=30, cameras=True).open()
    assert not (tmp_path / "cams").exists()
    with Recorder(tmp_path / "nocams", fps=30, cameras=False) as rec:
        assert rec.encoder is not None


def test_the_encoder_check_passes_with_pyav():
    from rio.recording.video import VideoOptions, video_problem

    pytest.importorskip("av")
    assert video_problem(VideoOptions()) is None
    assert video_problem(VideoOptions(codec="av1")) is None


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0,
                    reason="SVT-AV1 changes its caller's scheduling only when run as root")
def test_an_av1_stream_leaves_the_writers_thread_on_its_own_scheduling(tmp_path):
    """SVT-AV1 as root puts the thread that opens and feeds its encoder at SCHED_FIFO 99 and leaves it there
    (seen: every thread a test process started afterwards real-time, busy-waiting ones starving the machine)."""
    pytest.importorskip("av")
    from rio.recording.video import StreamWriter, VideoOptions

    before = (os.sched_getscheduler(0), os.sched_getparam(0))
    writer = StreamWriter(tmp_path / "rgb.mp4", "rgb", 48, 64, 30, VideoOptions(codec="av1", preset="12"))
    for _ in range(3):
        writer.write(np.zeros((48, 64, 3), np.uint8))
        assert (os.sched_getscheduler(0), os.sched_getparam(0)) == before
    assert writer.close() == 3
    assert (os.sched_getscheduler(0), os.sched_getparam(0)) == before
