"""`rio datasets merge`: native datasets of different morphologies (a 6-DOF single arm with two cameras
and depth, a bimanual pair, a 12-DOF humanoid with float32 state, a camera-less 7-DOF arm commanding
end-effector poses) into one padded dataset: shapes, masks, tags, values bit-identical to the sources,
videos copied byte for byte and decodable, checksums that verify, `info` showing the mix, a LeRobot v3
export read back with pyarrow, and every refusal in one line with nothing written."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from rio import clock
from rio.cli import main as rio_main
from rio.recording import DamagedEpisode, Dataset, Recorder
from rio.recording import merge as M
from rio.recording import paths as L
from rio.recording.synthetic import SyntheticCamera, record_synthetic, synthetic_step
from rio.schema import BimanualObs, HumanoidObs, Step

FPS = 30.0
SIZE = (32, 48)
TAGS = {"single": "single_arm@so100_single:joint_pos", "bimanual": "bimanual@so100_bimanual:joint_pos",
        "humanoid": "humanoid@g1_sim:joint_pos", "xarm": "single_arm@xarm7:eef_pose"}


def _env(name: str, parts: list[tuple[str, int]], station: str, cameras: tuple[str, ...]) -> SimpleNamespace:
    """What the recorder takes from an Env: station, embodiment name, action layout, whether it has cameras."""
    robot = SimpleNamespace(name=name, action_parts=lambda: parts)
    return SimpleNamespace(rate_hz=FPS, station=station, robot=robot, camera_clients=dict.fromkeys(cameras))


def _bimanual(i: int, t: float, cams: dict) -> Step:
    left, right = synthetic_step(i, t, cams), synthetic_step(i, t + 1.0)
    lo, ro = left.observation, right.observation
    obs = BimanualObs(proprio=np.concatenate([lo.proprio, ro.proprio]), cameras=lo.cameras,
                      arm1_proprio_eef=lo.proprio_eef, arm1_proprio_joints=lo.proprio_joints,
                      gripper1_width=lo.gripper_width, arm2_proprio_eef=ro.proprio_eef,
                      arm2_proprio_joints=ro.proprio_joints, gripper2_width=ro.gripper_width)
    meta = {**left.meta, "timestamps": {"arm": t, "gripper": t, "arm2": t, "gripper2": t}}
    return Step(i, obs, "fold the towel", np.concatenate([left.action, right.action]), meta)


def _humanoid(i: int, t: float, cams: dict) -> Step:
    s = synthetic_step(i, t, cams, dof=12)
    q = s.observation.proprio_joints.astype(np.float32)
    obs = HumanoidObs(proprio=q, joint_pos=q, joint_vel=np.cos(q), base_quat=np.array([1.0, 0.0, 0.0, 0.0]),
                      base_ang_vel=np.zeros(3), cameras=s.observation.cameras)
    return Step(i, obs, "wave", q + np.float32(0.01), {"t_obs": t, "timestamps": {"humanoid": t}})


def _xarm(i: int, t: float, cams: dict) -> Step:
    s = synthetic_step(i, t, cams, dof=7)
    s.action = np.concatenate([s.observation.proprio_eef, [s.observation.gripper_width]])
    s.observation.proprio = s.action.copy()
    return s


def _record(root: Path, make, *, episodes: int, steps: int, cameras: tuple[str, ...], env: SimpleNamespace,
            fps: float = FPS) -> Path:
    cams = {n: SyntheticCamera(*SIZE, seed=k + 5, noise=1.0) for k, n in enumerate(cameras)}
    with Recorder(root, fps=fps, env=env, video={"crf": 18}) as rec:
        for _ in range(episodes):
            t0 = clock.now()
            for i in range(steps):
                t = t0 + i / fps
                rec.add(make(i, t, {n: (c.frame(t), t) for n, c in cams.items()}))
            rec.keep()
    return root


def _tree(root: Path) -> dict[str, str]:
    """Every file under root by relative path -> sha256 (to prove the inputs are never modified)."""
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def sources(tmp_path_factory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("merge_src")
    single = tmp / "single"
    record_synthetic(str(single), episodes=2, steps=12, fps=FPS, size=SIZE, cameras=("front", "wrist"), depth=True,
                     video={"crf": 18},
                     env=_env("single_arm", [("joint_pos", 6), ("gripper", 1)], "so100_single", ("front", "wrist")))
    bim_parts = [("arm1_joint_pos", 6), ("arm1_gripper", 1), ("arm2_joint_pos", 6), ("arm2_gripper", 1)]
    return {
        "single": single,
        "bimanual": _record(tmp / "bimanual", _bimanual, episodes=2, steps=10, cameras=("front", "left_wrist"),
                            env=_env("bimanual", bim_parts, "so100_bimanual", ("front", "left_wrist"))),
        "humanoid": _record(tmp / "humanoid", _humanoid, episodes=1, steps=8, cameras=("head",),
                            env=_env("humanoid", [("joint_pos", 12)], "g1_sim", ("head",))),
        "xarm": _record(tmp / "xarm", _xarm, episodes=1, steps=6, cameras=(),
                        env=_env("single_arm", [("eef_pose", 7), ("gripper", 1)], "xarm7", ())),
    }


@pytest.fixture(scope="module")
def merged(sources, tmp_path_factory) -> tuple[Path, dict, list[str], dict[str, dict[str, str]]]:
    before = {k: _tree(p) for k, p in sources.items()}
    out = tmp_path_factory.mktemp("merge_out") / "merged"
    lines: list[str] = []
    result = M.merge_datasets([sources[k] for k in ("single", "bimanual", "humanoid", "xarm")], out,
                              progress=lines.append)
    return out, result, lines, before


def _origin(sources: dict[str, Path], ep) -> tuple[str, object]:
    """(source key, source Episode) of a merged episode."""
    src = ep.meta["merge"]["source"]
    key = next(k for k, p in sources.items() if str(p) == src["dataset"])
    return key, Dataset(sources[key]).episode(src["index"])


# -- the padded layout ------------------------------------------------------------------------------
def test_padded_shapes_masks_and_tags(sources, merged):
    out, result, lines, _ = merged
    ds = Dataset(out)
    assert len(ds) == 6 and [e["index"] for e in ds.episodes] == list(range(6))
    eps = list(ds)
    assert all(e.schema.fields == eps[0].schema.fields for e in eps)  # one layout: every exporter sees one
    dt = eps[0].schema.dtype
    assert dt["obs.proprio"].shape == (14,) and dt["obs.proprio"].base == np.float64  # float32 humanoid promoted
    assert dt["action"].shape == (14,) and dt["obs.proprio_joints"].shape == (7,)
    assert dt["obs.joint_pos"].shape == (12,) and dt["obs.arm2_proprio_eef"].shape == (7,)
    assert {n for n in eps[0].schema.names if n.startswith("cam.")} == {
        "cam.front.rgb", "cam.front.depth", "cam.wrist.rgb", "cam.left_wrist.rgb", "cam.head.rgb"}
    assert result["embodiments"] == {TAGS["single"]: 2, TAGS["bimanual"]: 2, TAGS["humanoid"]: 1, TAGS["xarm"]: 1}
    assert [ep.meta["merge"]["embodiment"]["tag"] for ep in eps] == [
        TAGS["single"], TAGS["single"], TAGS["bimanual"], TAGS["bimanual"], TAGS["humanoid"], TAGS["xarm"]]
    tag = eps[2].meta["merge"]["embodiment"]
    assert (tag["station"], tag["embodiment"], tag["action_space"], tag["action_dim"]) == (
        "so100_bimanual", "bimanual", "joint_pos", 14)
    # masks: real entries first, padding after; a field the source lacked is all false
    np.testing.assert_array_equal(M.mask(eps[0], "action"), [True] * 7 + [False] * 7)
    np.testing.assert_array_equal(M.mask(eps[4], "obs.proprio"), [True] * 12 + [False] * 2)
    np.testing.assert_array_equal(M.mask(eps[5], "action"), [True] * 8 + [False] * 6)
    np.testing.assert_array_equal(M.mask(eps[0], "obs.proprio_joints"), [True] * 6 + [False])
    assert not M.mask(eps[0], "obs.arm1_proprio_eef").any() and M.real_values(eps[0], "obs.arm1_proprio_eef") is None
    assert not eps[0].column("obs.arm1_proprio_eef").any()
    assert eps[2].meta["merge"]["fields"]["obs.joint_pos"]["shape"] is None
    # cameras: the union; an episode lacking one has no stream, -1 frame indices, and says so
    assert result["streams"] == ["front.depth", "front.rgb", "head.rgb", "left_wrist.rgb", "wrist.rgb"]
    m = eps[2].meta["merge"]
    assert m["absent_streams"] == ["front.depth", "head.rgb", "wrist.rgb"] and m["absent_cameras"] == ["head", "wrist"]
    assert sorted(eps[2].streams) == ["front.rgb", "left_wrist.rgb"]
    assert (eps[2].column("cam.wrist.rgb") == -1).all() and (eps[5].column("cam.front.rgb") == -1).all()
    assert eps[5].meta["merge"]["absent_cameras"] == ["front", "head", "left_wrist", "wrist"]
    # progress: one line per input dataset while verifying, one while writing
    assert len(lines) == 8 and all(str(sources[k]) in line for k, line in zip(
        ["single", "bimanual", "humanoid", "xarm"] * 2, lines, strict=True))
    index = json.loads((out / L.INDEX).read_text())
    assert index["embodiment"] == "mixed" and index["merge"]["embodiments"] == result["embodiments"]


def test_real_values_are_bit_identical_and_padding_is_zero(sources, merged):
    out = merged[0]
    for ep in Dataset(out):
        key, src = _origin(sources, ep)
        assert len(ep) == len(src) and ep.fps == src.fps
        for name in src.schema.names:
            got = M.real_values(ep, name)
            want = src.column(name)
            assert got is not None and got.dtype == want.dtype and got.shape == want.shape, (key, name)
            assert got.tobytes() == want.tobytes(), (key, name)  # bit for bit (NaN included)
        for name in ep.schema.names:
            if name.startswith("cam.") or name in ("timestep", "t", "t_recv"):
                continue
            col = ep.column(name)
            pad = ~np.broadcast_to(M.mask(ep, name), col.shape)
            assert not col[pad].any(), (key, name)  # zeros where nothing is real
        for cam in {n[4:] for n in src.schema.names if n.startswith("cam.")}:
            np.testing.assert_array_equal(ep.column(f"cam.{cam}"), src.column(f"cam.{cam}"))
        assert ep.instructions() == src.instructions() and ep.events() == src.events()
        step = next(ep.steps())
        assert type(step.observation).__name__ == src.schema.observation_class.rpartition(":")[2]
        assert ep.meta["station"] == src.meta["station"] and ep.meta["embodiment"] == src.meta["embodiment"]


def test_videos_are_copied_unchanged_and_decode(sources, merged):
    out = merged[0]
    checked = 0
    for ep in Dataset(out):
        _, src = _origin(sources, ep)
        assert sorted(ep.streams) == sorted(src.streams)
        for info in ep.streams.values():
            for name in (info["file"], info["frames_file"]):
                assert (ep.path / name).read_bytes() == (src.path / name).read_bytes()
                assert ep.meta["files"][name] == src.meta["files"][name]
            frames = list(ep.step_frames(info["camera"], info["kind"]))
            want = list(src.step_frames(info["camera"], info["kind"]))
            assert len(frames) == len(ep) and all(f is not None for f in frames)
            assert all(np.array_equal(a, b) for a, b in zip(frames, want, strict=True))
            checked += 1
    assert checked == 2 * 3 + 2 * 2 + 1  # single: front rgb+depth, wrist; bimanual: front, left_wrist; humanoid: head


def test_checksums_verify_and_inputs_are_untouched(sources, merged):
    out, _, _, before = merged
    ds = Dataset(out)
    assert ds.damaged() == {}
    for ep in ds:
        ep.check()
        for name in (L.STEPS, L.STEPS_SCHEMA):  # rewritten: recorded afresh
            assert ep.meta["files"][name]["sha256"] == hashlib.sha256((ep.path / name).read_bytes()).hexdigest()
    assert {k: _tree(p) for k, p in sources.items()} == before
    steps = out / "episode_000002" / L.STEPS  # and a merged episode is checked like any other
    good = steps.read_bytes()
    try:
        steps.write_bytes(bytes(len(good)))
        with pytest.raises(DamagedEpisode, match="episode_000002.*steps.bin"):
            Dataset(out).episode(2).column("action")
    finally:
        steps.write_bytes(good)
    assert Dataset(out).damaged() == {}


def test_info_shows_the_mix_of_embodiments(merged, capsys):
    out = merged[0]
    assert rio_main(["datasets", "info", str(out)]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert (f"embodiments: {TAGS['single']} (2 episodes), {TAGS['bimanual']} (2 episodes), "
            f"{TAGS['humanoid']} (1 episode), {TAGS['xarm']} (1 episode)") in text
    assert "verified" in text and "embodiment: mixed" in text
    assert rio_main(["datasets", "info", str(out), "--json", "--no-verify"]) == 0
    assert json.loads(capsys.readouterr().out)["embodiments"] == merged[1]["embodiments"]


def test_cli_merge_prints_progress_on_stderr_and_the_layout(sources, tmp_path, capsys):
    out = tmp_path / "two"
    assert rio_main(["datasets", "merge", str(sources["humanoid"]), str(sources["xarm"]), str(out)]) == 0
    cap = capsys.readouterr()
    err = [x for x in cap.err.splitlines() if x.strip()]
    assert len(err) == 4 and err[0].startswith("[1/2] verified") and err[3].startswith("[2/2] merged")
    text = " ".join(cap.out.split())
    assert f"merged 2 datasets into {out}: 2 episodes, 14 steps at 30 Hz" in text
    assert f"embodiments: {TAGS['humanoid']} (1), {TAGS['xarm']} (1)" in text
    assert "padded obs.proprio to (12,)" in text and "padded action to (12,)" in text
    assert Dataset(out).damaged() == {}


# -- LeRobot v3 -------------------------------------------------------------------------------------
def test_export_to_lerobot_v3_carries_masks_and_tags(merged, tmp_path, capsys):
    pytest.importorskip("rio_datasets")
    pq = pytest.importorskip("pyarrow.parquet")
    import av

    out = merged[0]
    lr = tmp_path / "lr"
    assert rio_main(["export", str(out), "--format", "lerobot", str(lr), "-o", "codec=h264"]) == 0, \
        capsys.readouterr().err
    info = json.loads((lr / "meta/info.json").read_text())
    feats = info["features"]
    assert info["codebase_version"] == "v3.0" and info["total_episodes"] == 6 and info["total_frames"] == 58
    assert info["robot_type"] == "bimanual+humanoid+single_arm"
    assert feats["observation.state"]["shape"] == [14] and feats["action"]["shape"] == [14]
    assert feats["mask.action"] == {"dtype": "bool", "shape": [14], "names": feats["action"]["names"]}
    assert feats["mask.observation.state"]["dtype"] == "bool" and feats["embodiment_index"]["dtype"] == "int64"
    cams = ["front", "head", "left_wrist", "wrist"]
    assert sorted(k.rpartition(".")[2] for k, f in feats.items() if f["dtype"] == "video") == cams
    assert all(feats[f"mask.observation.images.{c}"]["shape"] == [1] for c in cams)
    data = pq.read_table(lr / "data/chunk-000/file-000.parquet")
    assert set(feats) - {f"observation.images.{c}" for c in cams} == set(data.column_names)
    rio = json.loads((lr / "meta/rio.json").read_text())
    assert rio["embodiments"] == [TAGS["single"], TAGS["bimanual"], TAGS["humanoid"], TAGS["xarm"]]
    rows = sorted(pq.read_table(lr / "meta/episodes/chunk-000/file-000.parquet").to_pylist(),
                  key=lambda r: r["episode_index"])
    for e_i, (ep, row) in enumerate(zip(Dataset(out), rows, strict=True)):
        a, b = row["dataset_from_index"], row["dataset_to_index"]
        assert b - a == len(ep) == row["length"]
        part = data.slice(a, b - a)
        native = ep.column("action")  # exported: the command issued after each observation (the next row's)
        np.testing.assert_array_equal(np.asarray(part.column("action").to_pylist(), np.float32),
                                      np.concatenate([native[1:], native[-1:]]).astype(np.float32))
        masks = np.asarray(part.column("mask.action").to_pylist())
        assert masks.shape == (len(ep), 14) and (masks == M.mask(ep, "action")).all()
        assert (np.asarray(part.column("mask.observation.state").to_pylist()) == M.mask(ep, "obs.proprio")).all()
        for c in cams:
            assert set(part.column(f"mask.observation.images.{c}").to_pylist()) == {f"{c}.rgb" in ep.streams}
        assert set(part.column("embodiment_index").to_pylist()) == {
            rio["embodiments"].index(ep.meta["merge"]["embodiment"]["tag"])}
        assert rio["episodes"][e_i]["merge"]["embodiment"] == ep.meta["merge"]["embodiment"]
    # every camera's video has one frame per step; frames of an episode lacking the camera are black
    for c in cams:
        with av.open(str(lr / f"videos/observation.images.{c}/chunk-000/file-000.mp4")) as v:
            frames = [f.to_ndarray(format="rgb24") for f in v.decode(video=0)]
        assert len(frames) == 58
        for ep, row in zip(Dataset(out), rows, strict=True):
            seg = frames[row["dataset_from_index"]:row["dataset_to_index"]]
            if f"{c}.rgb" in ep.streams:
                assert np.mean(seg[0]) > 20
            else:
                assert max(int(f.max()) for f in seg) < 8


# -- refusals ---------------------------------------------------------------------------------------
def _refused(capsys, argv: list[str], *words: str) -> str:
    code = rio_main(["datasets", "merge", *argv])
    err = capsys.readouterr().err
    # progress lines of the inputs verified before the refusal may come first; the error is one line
    lines = [x for x in err.splitlines() if x.strip() and not x.startswith("[")]
    assert code != 0 and len(lines) == 1 and lines[0].startswith("error:") and "Traceback" not in err, err
    assert err.rstrip().splitlines()[-1] == lines[0], err
    line = " ".join(err.split())
    for w in words:
        assert w in line, line
    return line


def test_refuses_fewer_than_two_inputs_and_a_bad_output(sources, tmp_path, capsys):
    a, b = str(sources["humanoid"]), str(sources["xarm"])
    _refused(capsys, [a, str(tmp_path / "o1")], "at least two datasets")
    _refused(capsys, [a, a, str(tmp_path / "o2")], "given twice")
    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "x").write_text("keep me")
    _refused(capsys, [a, b, str(busy)], str(busy), "not an empty directory")
    assert [p.name for p in busy.iterdir()] == ["x"]
    _refused(capsys, [a, b, str(sources["xarm"] / "merged")], "inside an input")
    _refused(capsys, [a, str(tmp_path / "missing"), str(tmp_path / "o3")], "does not exist")
    empty = tmp_path / "empty"
    empty.mkdir()
    _refused(capsys, [a, str(empty), str(tmp_path / "o4")], "not a RIO dataset")
    assert not any((tmp_path / f"o{k}").exists() for k in range(1, 5))
    assert not (sources["xarm"] / "merged").exists()


def test_refuses_different_rates(sources, tmp_path, capsys):
    fast = tmp_path / "fast"
    record_synthetic(str(fast), episodes=1, steps=4, fps=50.0, cameras=())
    _refused(capsys, [str(sources["xarm"]), str(fast), str(tmp_path / "out")],
             "different rates", "30 Hz", "50 Hz", "does not resample")
    assert not (tmp_path / "out").exists()


def test_refuses_a_damaged_input_before_writing_anything(sources, tmp_path, capsys):
    bad = tmp_path / "bad"
    shutil.copytree(sources["xarm"], bad)
    steps = bad / "episode_000000" / L.STEPS
    steps.write_bytes(bytes(steps.stat().st_size))
    _refused(capsys, [str(sources["humanoid"]), str(bad), str(tmp_path / "out")],
             "episode_000000: damaged episode: steps.bin: changed since it was recorded", "merge refuses")
    assert not (tmp_path / "out").exists()
    with pytest.raises(DamagedEpisode):
        M.merge_datasets([sources["humanoid"], bad], tmp_path / "out2")
    assert not (tmp_path / "out2").exists()


def test_a_failing_merge_removes_what_it_wrote(sources, tmp_path, monkeypatch):
    calls = []
    real = M._write_episode

    def fail_second(*a, **k):
        calls.append(1)
        if len(calls) == 2:
            raise OSError(28, "No space left on device")
        return real(*a, **k)

    monkeypatch.setattr(M, "_write_episode", fail_second)
    with pytest.raises(OSError):
        M.merge_datasets([sources["humanoid"], sources["xarm"]], tmp_path / "out")
    assert not (tmp_path / "out").exists()
    (tmp_path / "empty").mkdir()
    calls.clear()
    with pytest.raises(OSError):
        M.merge_datasets([sources["humanoid"], sources["xarm"]], tmp_path / "empty")
    assert (tmp_path / "empty").is_dir() and not any((tmp_path / "empty").iterdir())


def test_fields_that_cannot_be_padded_are_refused(sources, tmp_path):
    """A field that is a vector in one input and a matrix in another has no padded shape."""
    odd = tmp_path / "odd"

    def matrix(i: int, t: float, cams: dict) -> Step:
        s = synthetic_step(i, t, cams)
        s.observation.proprio_eef = np.eye(3)
        return s

    _record(odd, matrix, episodes=1, steps=3, cameras=(), env=_env("single_arm", [("joint_pos", 6)], "odd", ()))
    with pytest.raises(M.MergeError, match=r"obs.proprio_eef.*cannot be padded"):
        M.merge_datasets([sources["xarm"], odd], tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_merging_a_merged_dataset_keeps_masks_and_tags(sources, merged, tmp_path):
    """Padding from an earlier merge is never taken for data: masks, original shapes and tags carry over."""
    again = tmp_path / "again"
    odd = tmp_path / "wide"

    def wide(i: int, t: float, cams: dict) -> Step:
        return synthetic_step(i, t, cams, dof=17)  # proprio and action of 18: wider than anything before

    _record(odd, wide, episodes=1, steps=3, cameras=(), env=_env("single_arm", [("joint_pos", 17)], "wide", ()))
    result = M.merge_datasets([merged[0], odd], again)
    assert result["episodes"] == 7
    eps = list(Dataset(again))
    assert eps[0].schema.dtype["action"].shape == (18,)
    np.testing.assert_array_equal(M.mask(eps[0], "action"), [True] * 7 + [False] * 11)
    assert eps[4].meta["merge"]["embodiment"]["tag"] == TAGS["humanoid"]
    assert eps[0].meta["merge"]["source"]["merged_from"]["dataset"] == str(sources["single"])
    for ep in eps[:6]:
        _, src = _origin({k: merged[0] for k in ["merged"]}, ep)
        first = Dataset(Path(src.meta["merge"]["source"]["dataset"])).episode(src.meta["merge"]["source"]["index"])
        for name in first.schema.names:
            assert M.real_values(ep, name).tobytes() == first.column(name).tobytes(), name
    assert Dataset(again).damaged() == {}


def test_the_merged_export_loads_in_lerobot_itself(merged, tmp_path, capsys):
    """Where LeRobot is installed (not in this workspace: run it in a LeRobot environment), its own
    `LeRobotDataset` reads the merged export: padded state and actions, the masks and the embodiment
    index come back per frame, with every camera (black frames where an episode had none)."""
    pytest.importorskip("rio_datasets")
    pytest.importorskip("lerobot")
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    out = merged[0]
    lr = tmp_path / "lr"
    assert rio_main(["export", str(out), "--format", "lerobot", str(lr), "-o", "codec=h264"]) == 0, \
        capsys.readouterr().err
    ds = LeRobotDataset("local/merged", root=lr, video_backend="pyav")
    assert ds.num_episodes == 6 and ds.num_frames == 58
    first, last = ds[0], ds[len(ds) - 1]
    for item in (first, last):
        assert tuple(item["action"].shape) == (14,) and tuple(item["mask.action"].shape) == (14,)
        assert item["mask.action"].dtype.is_floating_point is False
        for cam in ("front", "head", "left_wrist", "wrist"):
            assert item[f"observation.images.{cam}"].shape[0] == 3
    masks = {int(ds[i]["embodiment_index"]): ds[i]["mask.action"].sum().item() for i in range(len(ds))}
    assert len(masks) == 4 and max(masks.values()) == 14 and min(masks.values()) < 14
