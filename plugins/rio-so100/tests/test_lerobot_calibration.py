"""LeRobot calibrations imported into RIO: files laid out and written the way LeRobot 0.4.x writes
them (follower and leader, SO-100 and SO-101, the per-model folders of <= 0.4.2 and the shared ones of
>= 0.4.3), the same encoder readings giving the same angles as LeRobot's normalisation, round trips,
discovery through LeRobot's environment variables, `rio so100 calibrate --from-lerobot` in process and
as a subprocess, one-line errors for bad files, and an emulated arm driven with an imported calibration.

`lerobot_*` below is LeRobot's arithmetic as read in its `MotorsBus._normalize` / `_unnormalize` and the
Feetech homing offset (Present_Position = encoder - Homing_Offset): the reference the conversion is
checked against, written independently of `rio_so100.lerobot_calibration`.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from rio_so100.calibrate import Calibrator
from rio_so100.calibration import RAD_PER_STEP, ArmCalibration, default_calibration, load_calibration
from rio_so100.emulator.hand import CalibrationHand
from rio_so100.errors import CalibrationError
from rio_so100.feetech import control_table as T
from rio_so100.feetech.bus import FeetechBus
from rio_so100.follower.driver import So100Follower
from rio_so100.gripper.driver import So100Gripper
from rio_so100.lerobot_calibration import (
    from_lerobot,
    import_lerobot,
    lerobot_calibration_dir,
    lerobot_json,
    to_lerobot,
)
from rio_so100.models import ARM_IDS, ARM_JOINTS, GRIPPER, GRIPPER_ID

from rio import ServerManager, connect, serve
from rio.cli import main
from rio.testing import wait_until

MOTORS = (*ARM_JOINTS, GRIPPER)
LEROBOT_MAX_RES = 4095  # LeRobot's model_resolution_table["sts3215"] - 1
ENV = ("HF_LEROBOT_CALIBRATION", "HF_LEROBOT_HOME", "HF_HOME", "XDG_CACHE_HOME", "LEROBOT_HOME")


def _file(rows) -> dict:
    """A LeRobot calibration dict from (homing_offset, range_min, range_max) per motor, ids 1-6."""
    return {m: {"id": i + 1, "drive_mode": 0, "homing_offset": off, "range_min": lo, "range_max": hi}
            for i, (m, (off, lo, hi)) in enumerate(zip(MOTORS, rows, strict=True))}


# Plausible files as `lerobot-calibrate` leaves them. The SO-100 (and, from 0.4.3, the SO-101) does not
# record the wrist roll: 0..4095. The SO-101 of 0.4.0-0.4.2 did.
SO100_FOLLOWER = _file([(-1470, 758, 3292), (157, 612, 3401), (-1276, 869, 3091), (1897, 833, 3197),
                        (-1212, 0, 4095), (1400, 2037, 3499)])
SO100_LEADER = _file([(903, 803, 3300), (-1722, 709, 3364), (1002, 906, 3076), (-212, 850, 3204),
                      (77, 0, 4095), (-1650, 2028, 3243)])
SO101_FOLLOWER = _file([(-811, 742, 3421), (1106, 834, 3293), (-1999, 888, 3088), (610, 870, 3255),
                        (-95, 136, 3914), (1042, 2017, 3485)])
SO101_LEADER = _file([(45, 712, 3410), (-983, 820, 3308), (1750, 900, 3120), (-1500, 841, 3270),
                      (2001, 0, 4095), (-33, 1990, 3377)])

#: (LeRobot folder, its file, the model and device it means); the first four as LeRobot <= 0.4.2
#: lays them out, the last two as >= 0.4.3 does (one folder for both models).
LAYOUTS = [
    ("robots/so100_follower", SO100_FOLLOWER, "so100", "follower"),
    ("robots/so101_follower", SO101_FOLLOWER, "so101", "follower"),
    ("teleoperators/so100_leader", SO100_LEADER, "so100", "leader"),
    ("teleoperators/so101_leader", SO101_LEADER, "so101", "leader"),
    ("robots/so_follower", SO101_FOLLOWER, None, "follower"),
    ("teleoperators/so_leader", SO100_LEADER, None, "leader"),
]


def write_lerobot(root, folder: str, lerobot_id: str, data: dict):
    """As LeRobot's `_save_calibration` does: draccus json dump, indent 4, no final newline."""
    path = root / folder / f"{lerobot_id}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=4))
    return path


# -- LeRobot's arithmetic (the reference) ---------------------------------------------------------

def lerobot_present(encoder, homing_offset):
    """What a Feetech servo reports: Present_Position = encoder - Homing_Offset, on a 12-bit encoder."""
    return np.mod(np.asarray(encoder) - homing_offset, 4096)


def lerobot_normalize(mode: str, p, c: dict):
    p = np.asarray(p, dtype=np.float64)
    lo, hi, drive = c["range_min"], c["range_max"], c["drive_mode"]
    if mode == "degrees":  # not clipped, drive_mode ignored
        return (p - (lo + hi) / 2) * 360 / LEROBOT_MAX_RES
    bounded = np.clip(p, lo, hi)
    if mode == "range_m100_100":
        n = (bounded - lo) / (hi - lo) * 200 - 100
        return -n if drive else n
    n = (bounded - lo) / (hi - lo) * 100  # range_0_100
    return 100 - n if drive else n


def lerobot_unnormalize_degrees(value: float, c: dict) -> int:
    return int(value * LEROBOT_MAX_RES / 360 + (c["range_min"] + c["range_max"]) / 2)


def expected_rad(p, c: dict):
    """RIO's documented reading of a LeRobot joint: LeRobot's degrees in radians, rescaled from 4095 to 4096
    steps per turn, plus half a step when the range's middle is not a whole step; sign from drive_mode."""
    half = 0.5 * RAD_PER_STEP * ((c["range_min"] + c["range_max"]) % 2)
    sign = -1 if c["drive_mode"] else 1
    return sign * (np.radians(lerobot_normalize("degrees", p, c)) * LEROBOT_MAX_RES / 4096 + half)


def random_lerobot(rng, drive_modes=True) -> dict:
    out = {}
    for i, m in enumerate(MOTORS):
        lo = int(rng.integers(0, 3000))
        hi = int(rng.integers(lo + 1, 4096))
        out[m] = {"id": i + 1, "drive_mode": int(rng.integers(0, 2)) if drive_modes and m != GRIPPER else 0,
                  "homing_offset": int(rng.integers(-2047, 2048)), "range_min": lo, "range_max": hi}
    return out


@pytest.fixture
def lerobot_root(tmp_path, monkeypatch):
    """LeRobot's calibration folder in a temp dir, found through HF_LEROBOT_CALIBRATION."""
    for var in ENV:
        monkeypatch.delenv(var, raising=False)
    root = tmp_path / "lerobot-calibration"
    monkeypatch.setenv("HF_LEROBOT_CALIBRATION", str(root))
    return root


# -- reading the files --------------------------------------------------------------------------------

@pytest.mark.parametrize("folder, data, model, device", LAYOUTS, ids=[x[0] for x in LAYOUTS])
def test_every_layout_lerobot_writes_is_found_and_read(lerobot_root, folder, data, model, device):
    path = write_lerobot(lerobot_root, folder, "my_arm", data)
    by_id, found = import_lerobot("my_arm", model=None if model else "so101")
    by_path, _ = import_lerobot(str(path), model=None if model else "so101")
    assert found.path == path and by_id == by_path
    assert (by_id.model, by_id.device, by_id.name) == (model or "so101", device, "my_arm")
    assert list(by_id.joints) == list(MOTORS)
    for motor, c in data.items():
        jc = by_id.joint(motor)
        assert (jc.id, jc.homing_offset, jc.range_min, jc.range_max, jc.sign) == (
            c["id"], c["homing_offset"], c["range_min"], c["range_max"], 1)
        assert jc.zero == (c["range_min"] + c["range_max"]) // 2
    assert [by_id.joint(m).id for m in MOTORS] == [*ARM_IDS, GRIPPER_ID]


def test_a_file_outside_lerobots_folders_takes_model_and_device_from_the_caller(tmp_path):
    path = write_lerobot(tmp_path, "copied", "arm", SO101_LEADER)
    cal, found = import_lerobot(str(path))
    assert (found.model, found.device) == (None, None) and (cal.model, cal.device) == ("so100", "follower")
    cal, _ = import_lerobot(str(path), model="so101", device="leader", name="right")
    assert (cal.model, cal.device, cal.name) == ("so101", "leader", "right")


# -- the same readings give the same angles ----------------------------------------------------------

def _check_same_angles(data: dict, cal: ArmCalibration, encoder=None) -> int:
    """Encoder positions (default: the whole circle, wrapped twice) of every motor: RIO's reading of the
    servo's Present_Position against LeRobot's, in each of LeRobot's modes. Returns how many readings
    were compared."""
    encoder = np.arange(-4096, 8192) if encoder is None else encoder
    n = 0
    for motor, c in data.items():
        jc = cal.joint(motor)
        p = lerobot_present(encoder, c["homing_offset"])
        rio_rad = np.array([jc.to_rad(v) for v in p])
        np.testing.assert_allclose(rio_rad, expected_rad(p, c), rtol=0, atol=1e-12)
        # within half a step (+ LeRobot's 4095/4096 scale) of LeRobot's degrees
        deg = lerobot_normalize("degrees", p, c) * (-1 if c["drive_mode"] else 1)
        assert np.all(np.abs(np.degrees(rio_rad) - deg) <= 0.5 * 360 / 4096 + np.abs(deg) / 4096 + 1e-9)
        # the range modes: the jaw's fraction is LeRobot's range_0_100 / 100; arm joints move the same way
        # as LeRobot's range_m100_100 (a fraction of the range, direction from drive_mode)
        frac = np.array([jc.fraction(v) for v in p])
        if motor == GRIPPER:
            np.testing.assert_allclose(frac * 100, lerobot_normalize("range_0_100", p, c), rtol=0, atol=1e-9)
        else:
            m100 = lerobot_normalize("range_m100_100", p, c)
            np.testing.assert_allclose(jc.sign * (frac * 200 - 100), m100, rtol=0, atol=1e-9)
            inside = np.sort(np.unique(p[(p > c["range_min"]) & (p < c["range_max"])]))
            assert np.all(np.sign(np.diff([jc.to_rad(v) for v in inside]))
                          == np.sign(np.diff(lerobot_normalize("range_m100_100", inside, c))))
        # goals: an angle LeRobot would send (degrees) lands on the same step, give or take LeRobot's int()
        for d in np.linspace(*lerobot_normalize("degrees", [c["range_min"], c["range_max"]], c), 41):
            rad = expected_rad(d * LEROBOT_MAX_RES / 360 + (c["range_min"] + c["range_max"]) / 2, c)
            assert abs(jc.to_steps(float(rad)) - lerobot_unnormalize_degrees(d, c)) <= 1
        n += len(p)
    return n


@pytest.mark.parametrize("data", [SO100_FOLLOWER, SO100_LEADER, SO101_FOLLOWER, SO101_LEADER],
                         ids=["so100-follower", "so100-leader", "so101-follower", "so101-leader"])
def test_converted_calibration_reads_lerobots_angles(data):
    cal = from_lerobot(data, model="so100", device="follower", name="x")
    assert _check_same_angles(data, cal) == 6 * 3 * 4096


def test_same_angles_on_random_calibrations_with_reversed_joints():
    rng = np.random.default_rng(7)
    for _ in range(40):
        data = random_lerobot(rng)
        encoder = rng.integers(-4096, 8192, 400)
        assert _check_same_angles(data, from_lerobot(data, model="so101", device="leader", name="r"), encoder) == 2400


def test_zero_is_the_middle_of_the_range_not_the_held_pose():
    # LeRobot's calibration held the arm where it read 2047; the range is asymmetric around that pose
    data = _file([(0, 1000, 3500)] * 5 + [(0, 2047, 3000)])
    jc = from_lerobot(data, model="so100", device="follower", name="x").joint("shoulder_pan")
    assert jc.zero == 2250 and jc.to_rad(2250) == 0.0 and lerobot_normalize("degrees", 2250, data["shoulder_pan"]) == 0
    assert jc.to_rad(2047) == pytest.approx(-203 * RAD_PER_STEP)


# -- round trips ----------------------------------------------------------------------------------------

def test_lerobot_to_rio_to_lerobot_is_the_same_file():
    rng = np.random.default_rng(3)
    for data in [SO100_FOLLOWER, SO100_LEADER, SO101_FOLLOWER, SO101_LEADER] + [random_lerobot(rng)
                                                                                  for _ in range(50)]:
        cal = from_lerobot(data, model="so101", device="follower", name="x")
        assert to_lerobot(cal) == data
        assert lerobot_json(cal) == json.dumps(data, indent=4)  # byte for byte what LeRobot writes
        assert list(to_lerobot(cal)["gripper"]) == ["id", "drive_mode", "homing_offset", "range_min", "range_max"]


def test_rio_to_lerobot_to_rio(tmp_path, config_home):
    rng = np.random.default_rng(5)
    for data in [SO101_FOLLOWER] + [random_lerobot(rng) for _ in range(50)]:
        cal = from_lerobot(data, model="so100", device="leader", name="x")
        assert from_lerobot(to_lerobot(cal), model="so100", device="leader", name="x") == cal
        # and through both files: RIO's JSON and LeRobot's
        path = tmp_path / "c.json"
        path.write_text(cal.to_json())
        again = load_calibration(str(path), "so100", "leader")
        assert from_lerobot(json.loads(lerobot_json(again)), model="so100", device="leader", name="x") == cal
    # A calibration recorded by RIO keeps everything but `zero`: LeRobot's file has none, LeRobot counts from
    # the middle of the range, so 0 rad moves there from the held pose.
    native = default_calibration("so101", "follower", "x")
    native.joints["gripper"].range_max += 1  # an odd range sum: the middle is rounded down
    back = from_lerobot(to_lerobot(native), model="so101", device="follower", name="x")
    for motor in MOTORS:
        a, b = native.joint(motor), back.joint(motor)
        assert (a.id, a.homing_offset, a.range_min, a.range_max, a.sign) == (
            b.id, b.homing_offset, b.range_min, b.range_max, b.sign)
        assert b.zero == (a.range_min + a.range_max) // 2
    assert back.joint("gripper").zero != native.joint("gripper").zero


def test_reversed_joint_round_trips_through_sign():
    data = _file([(0, 1000, 3000)] * 6)
    data["elbow_flex"]["drive_mode"] = 1
    cal = from_lerobot(data, model="so100", device="follower", name="x")
    assert cal.joint("elbow_flex").sign == -1 and cal.joint("wrist_flex").sign == 1
    assert to_lerobot(cal)["elbow_flex"]["drive_mode"] == 1


# -- discovery --------------------------------------------------------------------------------------------

def test_lerobot_calibration_dir_follows_lerobots_variables(tmp_path, monkeypatch):
    for var in ENV:
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert lerobot_calibration_dir() == tmp_path / "home" / ".cache" / "huggingface" / "lerobot" / "calibration"
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert lerobot_calibration_dir() == tmp_path / "xdg" / "huggingface" / "lerobot" / "calibration"
    monkeypatch.setenv("HF_HOME", str(tmp_path / "hf"))
    assert lerobot_calibration_dir() == tmp_path / "hf" / "lerobot" / "calibration"
    monkeypatch.setenv("HF_LEROBOT_HOME", "~/lr")
    assert lerobot_calibration_dir() == tmp_path / "home" / "lr" / "calibration"
    monkeypatch.setenv("HF_LEROBOT_CALIBRATION", str(tmp_path / "cal"))
    assert lerobot_calibration_dir() == tmp_path / "cal"
    monkeypatch.setenv("HF_LEROBOT_CALIBRATION", "")  # empty: unset
    assert lerobot_calibration_dir() == tmp_path / "home" / "lr" / "calibration"
    assert lerobot_calibration_dir({"HF_HOME": "/x", "HF_LEROBOT_HOME": ""}) == Path("/x/lerobot/calibration")


def test_an_id_is_found_through_hf_lerobot_home(tmp_path, monkeypatch):
    for var in ENV:
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setenv("HF_LEROBOT_HOME", str(tmp_path / "lr"))
    write_lerobot(tmp_path / "lr" / "calibration", "teleoperators/so101_leader", "blue", SO101_LEADER)
    cal, found = import_lerobot("blue")
    assert (cal.model, cal.device, cal.name) == ("so101", "leader", "blue")
    assert found.path == tmp_path / "lr" / "calibration" / "teleoperators" / "so101_leader" / "blue.json"


# -- the command -------------------------------------------------------------------------------------------

def test_calibrate_from_lerobot_by_id(lerobot_root, config_home, capsys):
    write_lerobot(lerobot_root, "robots/so101_follower", "my_awesome_follower_arm", SO101_FOLLOWER)
    assert main(["so100", "calibrate", "--from-lerobot", "my_awesome_follower_arm"]) == 0
    out = capsys.readouterr().out
    saved = config_home / "rio" / "calibration" / "so101-follower" / "my_awesome_follower_arm.json"
    assert f"saved {saved}" in out and "as the so101 follower 'my_awesome_follower_arm'" in out
    assert "wrist_roll" in out and "rad" in out and "assumed" not in out
    cal = load_calibration("my_awesome_follower_arm", "so101", "follower")
    assert to_lerobot(cal) == SO101_FOLLOWER


def test_calibrate_from_lerobot_shared_folder_with_model_and_name(lerobot_root, config_home, capsys):
    # LeRobot >= 0.4.3: a bimanual pair's arms are <id>_left / <id>_right in the shared folder
    write_lerobot(lerobot_root, "teleoperators/so_leader", "pair_left", SO101_LEADER)
    assert main(["so100", "calibrate", "--from-lerobot", "pair_left", "--model", "so101", "--name", "left"]) == 0
    assert to_lerobot(load_calibration("left", "so101", "leader")) == SO101_LEADER
    assert main(["so100", "calibrate", "--from-lerobot", "pair_left", "--name", "left"]) == 0  # model: default
    out = capsys.readouterr().out
    assert "(LeRobot's folder does not say: assumed --model so100)" in out
    assert (config_home / "rio" / "calibration" / "so100-leader" / "left.json").is_file()
    assert main(["so100", "calibrate", "--from-lerobot", "pair_left", "--name", "left"]) == 0
    assert "(replacing the previous file)" in capsys.readouterr().out


def test_calibrate_from_lerobot_in_a_subprocess(tmp_path):
    path = write_lerobot(tmp_path / "lr", "robots/so100_follower", "main", SO100_FOLLOWER)
    env = {k: v for k, v in os.environ.items() if k not in ENV}
    env["XDG_CONFIG_HOME"] = str(tmp_path / "config")
    out = subprocess.run([sys.executable, "-m", "rio", "so100", "calibrate", "--from-lerobot", str(path),
                          "--name", "imported"], capture_output=True, text=True, timeout=120, env=env)
    assert out.returncode == 0, out.stderr
    saved = tmp_path / "config" / "rio" / "calibration" / "so100-follower" / "imported.json"
    assert f"saved {saved}" in out.stdout
    cal = ArmCalibration.from_json(saved.read_text())
    assert cal.name == "imported" and to_lerobot(cal) == SO100_FOLLOWER


def test_calibrate_needs_a_port_or_a_lerobot_file(capsys, lerobot_root):
    assert main(["so100", "calibrate"]) == 2
    assert "--from-lerobot FILE|ID" in capsys.readouterr().err
    write_lerobot(lerobot_root, "robots/so100_follower", "a", SO100_FOLLOWER)
    assert main(["so100", "calibrate", "--from-lerobot", "a", "--port", "/dev/ttyACM0"]) == 2
    assert "leave out --port" in capsys.readouterr().err
    assert main(["so100", "calibrate", "--from-lerobot", ""]) == 2
    assert "must not be empty" in capsys.readouterr().err


def _bad(data_or_text) -> str:
    return data_or_text if isinstance(data_or_text, str) else json.dumps(data_or_text, indent=4)


def _with(motor, **fields) -> dict:
    data = json.loads(json.dumps(SO100_FOLLOWER))
    for k, v in fields.items():
        if v is None:
            del data[motor][k]
        else:
            data[motor][k] = v
    return data


BAD_FILES = [
    ("not json", "{\"shoulder_pan\": {\"id\": 1,", "not valid JSON"),
    ("a list", [1, 2], "expected an object of motors, found list"),
    ("missing motor", {m: c for m, c in SO100_FOLLOWER.items() if m != "wrist_roll"},
     "motor(s) wrist_roll missing"),
    ("other robot", {**SO100_FOLLOWER, "base_left_wheel": SO100_FOLLOWER["gripper"]},
     "motor(s) base_left_wheel are not SO-100/SO-101 motors"),
    ("missing field", _with("elbow_flex", range_max=None), "elbow_flex.range_max is missing"),
    ("text field", _with("wrist_flex", homing_offset="12"), 'wrist_flex.homing_offset is "12", not a whole number'),
    ("float field", _with("wrist_flex", range_min=800.5), "wrist_flex.range_min is 800.5, not a whole number"),
    ("offset too big", _with("shoulder_lift", homing_offset=3000), "shoulder_lift.homing_offset is 3000, outside "
                                                                   "-2047..2047"),
    ("empty range", _with("gripper", range_min=3000, range_max=3000), "gripper.range_min 3000 is not below range_max"),
    ("drive mode", _with("elbow_flex", drive_mode=2), "elbow_flex.drive_mode is 2, outside 0..1"),
    ("reversed jaw", _with("gripper", drive_mode=1), "gripper.drive_mode is 1"),
    ("same id", _with("gripper", id=5), "id 5 is given to more than one motor (wrist_roll, gripper)"),
    ("extra field", _with("gripper", torque=3), "gripper.torque is not a LeRobot motor calibration field"),
    ("entry not an object", {**SO100_FOLLOWER, "gripper": 7}, "gripper is 7, not an object"),
]


@pytest.mark.parametrize("what, content, message", BAD_FILES, ids=[b[0] for b in BAD_FILES])
def test_a_bad_file_is_one_line_naming_file_and_field(lerobot_root, capsys, what, content, message):
    path = lerobot_root / "robots" / "so100_follower" / "bad.json"
    path.parent.mkdir(parents=True)
    path.write_text(_bad(content))
    assert main(["so100", "calibrate", "--from-lerobot", "bad"]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("error:") and str(path) in err
    assert message in err
    with pytest.raises(CalibrationError, match=f"^{path}: "):
        import_lerobot(str(path))


@pytest.mark.parametrize("args, folder, message", [
    (["--model", "so100"], "robots/so101_follower", "LeRobot's folder so101_follower holds so101 calibrations, not "
                                                    "so100: leave out --model or pass --model so101"),
    (["--device", "leader"], "robots/so100_follower", "holds follower calibrations, not leader"),
    (["--device", "leader"], None, "holds follower calibrations, not leader"),
    ([], "robots/koch_follower", "LeRobot's folder robots/koch_follower is not an SO-100/SO-101 arm's"),
    ([], "nowhere", "no LeRobot calibration 'arm' in"),
    ([], "twice", "LeRobot calibration 'arm' is ambiguous: robots/so_follower/arm.json, "
                  "teleoperators/so_leader/arm.json; pass --device or --model"),
], ids=["wrong model", "wrong device by id", "wrong device by path", "other robot folder", "unknown id", "ambiguous"])
def test_the_wrong_arm_is_one_line(lerobot_root, capsys, args, folder, message):
    if folder == "twice":
        write_lerobot(lerobot_root, "robots/so_follower", "arm", SO100_FOLLOWER)
        write_lerobot(lerobot_root, "teleoperators/so_leader", "arm", SO100_LEADER)
        source = "arm"
    elif folder == "nowhere":
        write_lerobot(lerobot_root, "robots/so100_follower", "other", SO100_FOLLOWER)
        source = "arm"
    elif folder is None:
        source = str(write_lerobot(lerobot_root, "robots/so100_follower", "arm", SO100_FOLLOWER))
    else:
        path = write_lerobot(lerobot_root, folder, "arm", SO101_FOLLOWER)
        source = str(path) if "koch" in folder else "arm"
    assert main(["so100", "calibrate", "--from-lerobot", source, *args]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err
    if folder == "nowhere":
        assert "found: so100_follower/other" in err


def test_no_lerobot_folder_says_where_it_looked(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("HF_LEROBOT_CALIBRATION", str(tmp_path / "absent"))
    assert main(["so100", "calibrate", "--from-lerobot", "main"]) == 1
    err = capsys.readouterr().err
    assert f"LeRobot's calibration folder {tmp_path / 'absent'} does not exist" in err
    assert main(["so100", "calibrate", "--from-lerobot", str(tmp_path / "x.json")]) == 1
    assert f"{tmp_path / 'x.json'} does not exist" in capsys.readouterr().err


# -- the real boundary: an emulated arm driven with an imported calibration -----------------------------------

def test_emulated_arm_runs_on_an_imported_calibration(lerobot_root, vbus, config_home):
    data = SO101_FOLLOWER
    write_lerobot(lerobot_root, "robots/so101_follower", "my_follower", data)
    assert main(["so100", "calibrate", "--from-lerobot", "my_follower"]) == 0
    # the arm where LeRobot left it: readings (after its homing offsets) inside each range
    present = {"shoulder_pan": 1200, "shoulder_lift": 2900, "elbow_flex": 2047, "wrist_flex": 901,
               "wrist_roll": 3800, "gripper": 2500}
    with vbus.lock:
        for motor, c in data.items():
            vbus.servo(c["id"]).encoder = present[motor] + c["homing_offset"]
    kw = {"port": vbus.port, "calibration": "my_follower", "model": "so101"}
    with ServerManager("thread", [serve(So100Follower, name="arm", **kw), serve(So100Gripper, name="gripper", **kw)]):
        with connect(So100Follower, "thread", name="arm", **kw) as arm, \
                connect(So100Gripper, "thread", name="gripper", **kw) as gripper:
            # the driver put LeRobot's calibration into the servos, as LeRobot's write_calibration would
            for c in data.values():
                s = vbus.servo(c["id"])
                assert (s.homing_offset, s.reg(T.MIN_POSITION_LIMIT), s.reg(T.MAX_POSITION_LIMIT)) == (
                    c["homing_offset"], c["range_min"], c["range_max"])
            q = np.asarray(arm.get_state()["joint_pos"])
            want = [expected_rad(present[m], data[m]) for m in ARM_JOINTS]
            np.testing.assert_allclose(q, want, rtol=0, atol=1e-12)
            jaw = lerobot_normalize("range_0_100", present["gripper"], data["gripper"])  # LeRobot's 0..100
            assert gripper.get_state()["width"] == pytest.approx(jaw / 100 * 0.06)
            # a pose given in LeRobot's degrees, sent in radians: each servo ends where LeRobot would send it
            target_deg = {"shoulder_pan": 30.0, "shoulder_lift": -45.0, "elbow_flex": 20.0, "wrist_flex": -10.0,
                          "wrist_roll": 90.0}
            rad = [float(np.radians(target_deg[m]) * LEROBOT_MAX_RES / 4096
                         + 0.5 * RAD_PER_STEP * ((data[m]["range_min"] + data[m]["range_max"]) % 2))
                   for m in ARM_JOINTS]
            arm.move_joints(rad, time.monotonic() + 0.4)
            goal = {m: lerobot_unnormalize_degrees(target_deg[m], data[m]) for m in ARM_JOINTS}
            assert wait_until(lambda: all(abs(vbus.servo(data[m]["id"]).present() - goal[m]) <= 2 for m in ARM_JOINTS),
                              timeout=5.0)
            gripper.move(0.03, time.monotonic() + 0.2)  # half open: LeRobot's gripper 50
            c = data["gripper"]
            assert wait_until(lambda: abs(vbus.servo(6).present() - (c["range_min"] + c["range_max"]) / 2) <= 2)


def test_calibration_recorded_by_rio_runs_in_lerobots_arithmetic(vbus):
    """The other way: an arm calibrated by RIO, exported, reads in LeRobot's degrees what RIO reads in radians
    (up to the middle-of-range zero)."""
    hand = CalibrationHand(vbus, amplitude=700.0)
    joints = {**dict(zip(ARM_JOINTS, ARM_IDS, strict=True)), GRIPPER: GRIPPER_ID}
    with FeetechBus(vbus.port) as bus:
        cal = Calibrator(bus, joints)
        cal.prepare()
        hand.hold_middle()
        cal.record_middle()
        hand.sweep(0.4)
        t_end = time.monotonic() + 0.5
        while time.monotonic() < t_end:
            cal.sample()
            time.sleep(0.005)
        rio = cal.finish("so100", "follower", "native")
    exported = json.loads(lerobot_json(rio))
    for motor, c in exported.items():
        jc = rio.joint(motor)
        assert c["homing_offset"] == vbus.servo(c["id"]).homing_offset
        shift = jc.zero - (c["range_min"] + c["range_max"]) / 2
        for p in range(c["range_min"], c["range_max"] + 1, 37):
            assert math.isclose(jc.to_rad(p) + shift * RAD_PER_STEP,
                                math.radians(float(lerobot_normalize("degrees", p, c))) * LEROBOT_MAX_RES / 4096,
                                abs_tol=1e-12)
