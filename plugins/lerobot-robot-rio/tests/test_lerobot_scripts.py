"""LeRobot's own commands on a RIO station: `lerobot-record` with the rio teleoperator, the dataset read back
by `LeRobotDataset`, `lerobot-replay` of its episode, and a bad station's error. Each runs the real command
in a subprocess on the simulated SO-100 (rio-sim); about two minutes in all on two CPU cores."""

import pytest

pytest.importorskip("lerobot")
pytest.importorskip("lerobot_robot_rio")
pytest.importorskip("rio_sim")

import json  # noqa: E402
import os  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

STATION = "sim-so100"
FPS, SECONDS = 30, 3
REPO = "local/rio_sim_so100"
NAMES = ["shoulder_pan.pos", "shoulder_lift.pos", "elbow_flex.pos", "wrist_flex.pos", "wrist_roll.pos",
         "gripper.pos"]


def command(name: str) -> str:
    path = Path(sys.executable).parent / name
    if not path.exists():
        pytest.skip(f"{name} is not installed next to {sys.executable}")
    return str(path)


def run(args: list[str], cwd: Path, timeout: float = 240) -> subprocess.CompletedProcess:
    """A LeRobot command, offline, its calibration files under `cwd`, no display, output captured."""
    env = {**os.environ, "HF_HUB_OFFLINE": "1", "HF_LEROBOT_HOME": str(cwd / "hf_lerobot"), "PYTHONUNBUFFERED": "1"}
    env.pop("DISPLAY", None)
    return subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def tail(r: subprocess.CompletedProcess, n: int = 40) -> str:
    lines = [x for x in (r.stdout + r.stderr).splitlines() if not x.startswith("Svt[")]  # the AV1 encoder's chatter
    return "\n".join(lines[-n:])


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """One episode recorded by `lerobot-record` with the station's scripted teleop (pick and place)."""
    work = tmp_path_factory.mktemp("record")
    root = work / "dataset"
    r = run([command("lerobot-record"), "--robot.type=rio", f"--robot.station={STATION}",
             "--teleop.type=rio", f"--teleop.station={STATION}", "--teleop.device=scripted",
             f"--dataset.repo_id={REPO}", f"--dataset.root={root}", f"--dataset.fps={FPS}",
             "--dataset.num_episodes=1", f"--dataset.episode_time_s={SECONDS}", "--dataset.reset_time_s=0",
             "--dataset.push_to_hub=false", "--dataset.single_task=pick up the cube and place it",
             "--display_data=false", "--play_sounds=false"], work)
    assert r.returncode == 0, tail(r)
    return root


def test_lerobot_record_makes_a_dataset_lerobot_loads(recorded):
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset(REPO, root=recorded, video_backend="pyav")
    f = ds.meta.features
    assert ds.meta.robot_type == "rio" and ds.fps == FPS and ds.num_episodes == 1
    assert f["action"]["names"] == NAMES and f["observation.state"]["names"] == NAMES
    for cam in ("front", "wrist"):
        assert f[f"observation.images.{cam}"]["dtype"] == "video"
        assert tuple(f[f"observation.images.{cam}"]["shape"]) == (240, 320, 3)
    expected = FPS * SECONDS  # a loaded machine may lose some frames to a slow tick, never add any
    assert 0.6 * expected <= ds.num_frames <= expected + 2, ds.num_frames
    actions = np.stack([np.asarray(ds.hf_dataset[i]["action"]) for i in range(ds.num_frames)])
    states = np.stack([np.asarray(ds.hf_dataset[i]["observation.state"]) for i in range(ds.num_frames)])
    assert np.isfinite(actions).all() and np.isfinite(states).all()
    # the scripted pick and place moved the arm: actions and the measured state both show it
    assert np.ptp(actions[:, 0]) > 0.1 and np.ptp(states[:, 0]) > 0.05
    frame = ds[ds.num_frames // 2]
    for cam in ("front", "wrist"):
        img = frame[f"observation.images.{cam}"]
        assert tuple(img.shape) == (3, 240, 320)
    assert frame["task"] == "pick up the cube and place it"


REPLAY = """
import json, sys, time
import numpy as np
from lerobot_robot_rio import bridge

out, sent = sys.argv[1], []
send, stop = bridge.StationBridge.send, bridge.StationBridge.stop

def recording_send(self, action):
    sent.append(list(send(self, action).values()))
    return sent[-1]

def measuring_stop(self):  # what the station's arm did, read from its node before it stops
    if self.running:
        time.sleep(0.5)  # the last command's target lies one control period ahead
        s = self.env.robot.arm.get_state()
        json.dump({"sent": sent, "final_q": np.asarray(s["joint_pos"]).tolist(),
                   "gripper": float(self.env.robot.gripper.get_state()["width"])}, open(out, "w"))
    stop(self)

bridge.StationBridge.send, bridge.StationBridge.stop = recording_send, measuring_stop
sys.argv = ["lerobot-replay", *sys.argv[2:]]
from lerobot.scripts.lerobot_replay import main
main()
"""


def test_lerobot_replay_drives_the_arm(recorded, tmp_path):
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    command("lerobot-replay")
    ds = LeRobotDataset(REPO, root=recorded)
    actions = np.stack([np.asarray(ds.hf_dataset[i]["action"]) for i in range(ds.num_frames)]).astype(np.float64)
    out = tmp_path / "replay.json"
    r = run([sys.executable, "-c", REPLAY, str(out), "--robot.type=rio", f"--robot.station={STATION}",
             f"--dataset.repo_id={REPO}", f"--dataset.root={recorded}", "--dataset.episode=0",
             "--play_sounds=false"], tmp_path)
    assert r.returncode == 0, tail(r)
    seen = json.loads(out.read_text())
    sent = np.asarray(seen["sent"])
    assert sent.shape == actions.shape  # every frame went to the station, in order
    np.testing.assert_allclose(sent, actions, atol=1e-5)  # float32 in the dataset
    # the arm (a fresh station, at home) followed the commands to the episode's last action
    np.testing.assert_allclose(seen["final_q"], actions[-1, :5], atol=0.05)
    assert np.abs(actions[-1, :5] - actions[0, :5]).max() > 0.1
    assert seen["gripper"] == pytest.approx(actions[-1, 5], abs=0.005)


def test_unknown_station_is_one_line_from_lerobot(tmp_path):
    r = run([command("lerobot-record"), "--robot.type=rio", "--robot.station=no-such-station",
             "--teleop.type=rio", "--teleop.station=no-such-station", f"--dataset.repo_id={REPO}",
             f"--dataset.root={tmp_path / 'ds'}", "--dataset.single_task=t", "--dataset.push_to_hub=false",
             "--display_data=false", "--play_sounds=false"], tmp_path, timeout=120)
    assert r.returncode != 0
    last = (r.stdout + r.stderr).strip().splitlines()[-1]
    # LeRobot wraps it ("Error creating robot with config ...: <ours>"); ours is whole on that last line
    assert "unknown station 'no-such-station'" in last and "(or give the path of a .toml file)" in last, tail(r)
    assert not (tmp_path / "ds").exists()
