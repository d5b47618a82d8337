"""RLDS export: read back with TensorFlow Datasets' own reader (`tfds.builder_from_directory`) and compared
step by step with the native dataset (skipped where tensorflow-datasets is not installed: it is the
`rio-datasets[rlds]` extra, not in the workspace venv). Without the extra, the format says what to install."""

from __future__ import annotations

import builtins
import json

import numpy as np
import pytest
from rio_datasets.common import actions_after_observations

from rio.cli import main as rio_main
from rio.recording import Dataset
from rio.recording.format import export_dataset, get_format


@pytest.fixture(scope="module")
def source(tmp_path_factory):
    """Two episodes: a front and a wrist camera (depth on front), a force-torque column named `wrench`, and
    an instruction that changes halfway through the second episode."""
    from rio.recording.recorder import Recorder
    from rio.recording.synthetic import SyntheticCamera, synthetic_step

    root = tmp_path_factory.mktemp("rlds") / "pick_cube"
    cams = {n: SyntheticCamera(48, 64, seed=k, noise=1.0) for k, n in enumerate(("front", "wrist"))}
    with Recorder(root, fps=10, video={"crf": 18}, station="synthetic") as rec:
        rec.info.update(robot_type="rio.fake_arm", action_names=[f"j{i}" for i in range(6)] + ["gripper"])
        for e, n in enumerate((12, 9)):
            t0 = 100.0 * (e + 1)
            for i in range(n):
                t = t0 + i / 10
                text = "pick up the cube" if e == 0 or i < 5 else "put it down"
                step = synthetic_step(i, t, {c: (cam.frame(t), t) for c, cam in cams.items()}, instruction=text)
                step.meta["wrench"] = np.array([i, -i, 0.5, 0.0, 0.1 * e, 1.0])
                rec.add(step)
            rec.keep()
    return root


def test_without_the_extra_the_format_says_which_to_install(source, tmp_path, monkeypatch, capsys):
    real_import = builtins.__import__

    def no_tfds(name, *args, **kwargs):
        if name.startswith("tensorflow_datasets"):
            raise ModuleNotFoundError(f"No module named '{name}'", name=name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_tfds)
    out = tmp_path / "out"
    assert rio_main(["export", str(source), "--format", "rlds", str(out)]) == 1
    err = " ".join(capsys.readouterr().err.split())
    assert "pip install 'rio-datasets[rlds]'" in err and "Traceback" not in err
    assert not out.exists()


def test_rlds_steps_match_the_source(source, tmp_path):
    tfds = pytest.importorskip("tensorflow_datasets",
                               reason="tensorflow-datasets is not installed: the rio-datasets[rlds] extra")
    out = tmp_path / "rlds"
    result = export_dataset(get_format("rlds", {"image_encoding": "png", "main_camera": "front"}),
                            Dataset(source), out)
    assert result["name"] == "pick_cube" and result["skipped_streams"] == [] and "warnings" not in result
    builder = tfds.builder_from_directory(str(out / "pick_cube" / "1.0.0"))
    meta = builder.info.metadata
    assert meta["robot_type"] == "rio.fake_arm" and meta["control_rate_hz"] == 10.0
    assert meta["names"]["action"] == [f"j{i}" for i in range(6)] + ["gripper"]
    episodes = list(tfds.as_numpy(builder.as_dataset(split="train")))
    assert len(episodes) == 2
    for ep_src, ep in zip(Dataset(source), episodes, strict=True):
        steps = list(ep["steps"])
        n = len(ep_src)
        assert len(steps) == n
        assert ep["episode_metadata"]["file_path"].decode() == str(ep_src.path)
        state = ep_src.column("obs.proprio").astype(np.float32)
        action = actions_after_observations(ep_src.column("action")).astype(np.float32)
        wrench = ep_src.column("meta.wrench").astype(np.float32)
        front, wrist = list(ep_src.step_frames("front")), list(ep_src.step_frames("wrist"))
        texts = ep_src.instructions()
        for t, step in enumerate(steps):
            obs = step["observation"]
            np.testing.assert_array_equal(obs["state"], state[t])
            np.testing.assert_array_equal(step["action"], action[t])
            np.testing.assert_array_equal(obs["wrench"], wrench[t])
            np.testing.assert_array_equal(obs["image"], front[t])  # png: lossless
            np.testing.assert_array_equal(obs["wrist_image"], wrist[t])
            assert step["language_instruction"].decode() == texts[t]
            assert bool(step["is_first"]) == (t == 0) and bool(step["is_last"]) == (t == n - 1)
            assert bool(step["is_terminal"]) == (t == n - 1)
            assert step["reward"] == (1.0 if t == n - 1 else 0.0) and step["discount"] == 1.0
    assert {s["language_instruction"].decode() for s in episodes[1]["steps"]} == {"pick up the cube", "put it down"}


def test_rlds_cli_jpeg_default_and_metadata_file(source, tmp_path, capsys):
    pytest.importorskip("tensorflow_datasets", reason="tensorflow-datasets is not installed: the rlds extra")
    out = tmp_path / "rlds"
    assert rio_main(["export", str(source), "--format", "rlds", str(out), "-e", "1"]) == 0
    meta = json.loads((out / "pick_cube" / "1.0.0" / "metadata.json").read_text())
    assert meta["rio_episodes"] == [1] and meta["station"] == "synthetic"
    import tensorflow_datasets as tfds

    ep = next(iter(tfds.as_numpy(tfds.builder_from_directory(str(out / "pick_cube" / "1.0.0"))
                                 .as_dataset(split="train"))))
    first = next(iter(ep["steps"]))
    src = next(Dataset(source).episode(1).step_frames("front"))
    assert np.abs(first["observation"]["front_image"].astype(int) - src.astype(int)).mean() < 6  # jpeg
