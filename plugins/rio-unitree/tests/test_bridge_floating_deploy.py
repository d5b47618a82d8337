"""A locomotion policy deployed on `g1-sim-floating` through the unmodified `unitree.g1` driver over real DDS
on loopback: the gantry holds the free G1 while the station starts, lowers it once the driver holds the legs,
and the G1 then stands on its own feet, judged from the bridge's physics (pelvis height and tilt).

The model is the zero-ish ONNX model of rio-policies' locomotion tests (actions = 1e-4 x obs[0:12]: it holds
the policy's default pose, and its actions tell what it was given); no walking checkpoint is shipped."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("onnxruntime")
pytest.importorskip("onnx")
pytest.importorskip("mujoco")

STANDING_S = 5.0  # simulated seconds on its own feet


def station_in(domain_id: int, tmp_path: Path) -> str:
    """The packaged station, in this test's DDS domain (no other run on this machine hears it)."""
    import rio_unitree

    text = (Path(rio_unitree.__file__).parent / "stations" / "g1-sim-floating.toml").read_text()
    assert text.count("domain_id = 1 ") + text.count("domain_id = 1\n") == 2
    text = text.replace("domain_id = 1 ", f"domain_id = {domain_id} ").replace("domain_id = 1\n",
                                                                               f"domain_id = {domain_id}\n")
    path = tmp_path / "g1-sim-floating.toml"
    path.write_text(text)
    return str(path)


def tilt_deg(quat_wxyz) -> float:
    w, x, y, z = quat_wxyz
    return math.degrees(math.acos(max(-1.0, min(1.0, 1 - 2 * (x * x + y * y)))))


@pytest.mark.slow
def test_a_zero_policy_stands_the_free_g1_after_the_gantry_lowers_it(domain_id, tmp_path):
    pytest.importorskip("rio_sim")  # the G1 model that stands with these gains (the fallback is only G1-like)
    from rio_policies.locomotion import G1_DEFAULT_POSE, G1_JOINTS
    from rio_policies.testing import G1_STANDING, standing_policy

    from rio.workflows.deploy import run_deploy

    gain = 1e-4
    spec, _ = standing_policy(tmp_path, gain, command=[0.1, -0.05, 0.2])
    trace: list[tuple[float, float, float, float]] = []  # sim time, pelvis height, tilt, gantry load
    chunks: list = []

    def on_tick(tick):
        b = tick.step.meta["sensors"]["bridge"]
        trace.append((float(b["sim_time"]), float(b["base_pos"][2]), tilt_deg(b["base_quat"]),
                      float(b["gantry_load"])))
        if tick.info.get("chunk") is not None:
            chunks.append(tick.info["chunk"])
        released = [t for t, _, _, load in trace if load == 0.0 and t > 0.5]
        if released and trace[-1][0] > released[0] + STANDING_S + 0.2:
            raise KeyboardInterrupt  # the loop's stop, in simulated time however slow the machine

    summary = run_deploy(station_in(domain_id, tmp_path), str(spec), duration=240, on_tick=on_tick, log=None)
    t, h, tilt, load = np.array(trace).T
    assert load[0] == 1.0, "the gantry holds the G1 from the start"
    on_feet = (load == 0.0) & (t > 0.5)
    assert on_feet.any(), ("the gantry was never lowered", summary.format())
    t_free = t[on_feet][0]
    assert t[-1] > t_free + STANDING_S, (t[-1], t_free, summary.format())
    holding = load == 1.0
    assert h[holding].max() - h[holding].min() < 0.02 and tilt[holding].max() < 3.0  # it hung still
    lowering = (load > 0.0) & (load < 1.0)
    assert lowering.any() and np.all(np.diff(h[lowering | on_feet][:40]) > -0.01)  # no drop: < 0.5 m/s at 50 Hz
    after = t >= t_free
    assert h[after].min() > 0.6 and tilt[after].max() < 20.0, (h[after].min(), tilt[after].max(), summary.format())
    assert tilt[t > t_free + 2.0].max() < 6.0  # stands, not leaning
    assert summary.details["stats"]["chunks"] > 0.9 * summary.ticks, summary.format()  # the model ran at 50 Hz
    # what the model saw (its actions carry obs[0:12]): upright, the constant command
    default = np.array([G1_STANDING.get(j, G1_DEFAULT_POSE.get(j, 0.0)) for j in G1_JOINTS[:12]])
    late = [c for c in chunks if c.t_obs > chunks[0].t_obs + 3.0]
    seen = np.array([(c.actions[0][:12] - default) / (0.25 * gain) for c in late])
    np.testing.assert_allclose(seen[:, 3:6].mean(axis=0), [0, 0, -1], atol=0.1)
    np.testing.assert_allclose(seen[:, 6:9], np.tile([0.2, -0.1, 0.05], (len(late), 1)), atol=0.02)
