"""A device's keep / discard buttons decide a recorded episode's fate without a prompt; device options
from the command line (`--teleop-set`); robot state fed back to a device that asks for it."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from rio.cli.teleop_cmd import record_episodes
from rio.control.teleop import BUTTON_DISCARD, BUTTON_DONE, BUTTON_KEEP, episode_verdict
from rio.station.load import load_station
from rio.teleop.feedback import DeviceFeedback
from rio.testing import fake_eef_station
from rio.workflows.teleop import record_teleop, run_teleop

STATION = fake_eef_station("verdict-test", 'driver = "rio.fake_teleop"\nbuttons = 4', gripper=False)


@pytest.fixture
def station(tmp_path: Path) -> Path:
    path = tmp_path / "verdict.toml"
    path.write_text(STATION)
    return path


def test_episode_verdict_needs_done_and_prefers_discard():
    b = np.zeros(4, bool)
    assert episode_verdict(b) is None
    b[BUTTON_KEEP] = True
    assert episode_verdict(b) is None  # keep without done: the episode goes on
    b[BUTTON_DONE] = True
    assert episode_verdict(b) == "keep"
    b[BUTTON_DISCARD] = True
    assert episode_verdict(b) == "discard"
    assert episode_verdict(np.array([False, True])) is None  # a 2-button device: done only


def test_the_run_ends_with_the_devices_verdict(station):
    s = run_teleop(str(station), device_config={"pressed": [BUTTON_DONE, BUTTON_DISCARD]}, duration=20, log=None)
    assert s.details["verdict"] == "discard" and s.reason == "the device finished" and s.seconds < 15
    s = run_teleop(str(station), device_config={"pressed": [BUTTON_DONE]}, duration=20, log=None)
    assert "verdict" not in s.details


def test_record_keeps_and_discards_as_the_device_says(station, tmp_path):
    """Headless with --on-end keep, the device's discard still discards and the session goes on to
    the next episode (a headless `discard` from --on-end would stop it); one station session throughout."""
    root = tmp_path / "data"
    seq = [[BUTTON_DONE, BUTTON_DISCARD], [BUTTON_DONE, BUTTON_KEEP], [BUTTON_DONE, BUTTON_KEEP]]
    verdicts = []

    def run(rec, decide):
        def noting(summary, rec, stop):
            verdicts.append(summary.details.get("verdict"))
            return decide(summary, rec, stop)

        return record_teleop(str(station), rec, noting, device_config={"pressed_runs": seq,
                                                                       "twist": [0.02, 0, 0, 0, 0, 0]},
                             duration=20, log=None, reset_s=0.0)

    record_episodes(run, str(root), 2, "keep", load_station(str(station)), None, None, json_out=True)
    assert verdicts == ["discard", "keep", "keep"]
    kept = sorted(p.name for p in root.iterdir() if p.name.startswith("episode"))
    assert kept == ["episode_000000", "episode_000001"]
    assert len(list((root / ".discarded").iterdir())) == 1


def test_teleop_set_reaches_the_device(station):
    from typer.testing import CliRunner

    from rio.cli.app import build_app

    r = CliRunner().invoke(build_app(), ["teleop", str(station), "--teleop-set", "pressed=[1, 2]",
                                         "--teleop-set", "gripper=0.5", "--json"])
    assert r.exit_code == 0, r.output
    assert '"verdict": "keep"' in r.output
    r = CliRunner().invoke(build_app(), ["teleop", str(station), "--teleop-set", "gripper=7"])
    assert r.exit_code != 0 and "gripper" in r.output
    r = CliRunner().invoke(build_app(), ["teleop", str(station), "--teleop-set", "gripper"])
    assert r.exit_code != 0 and "key=value" in r.output


class _Arm:
    role, gripper = "arm", None

    class client:
        @staticmethod
        def get_state() -> dict[str, Any]:
            return {"eef_pose": np.array([0.1, 0.2, 0.3, 1, 0, 0, 0])}


def test_feedback_is_rate_limited_and_survives_a_device_that_stops_taking_it():
    got, said = [], []

    class Page:
        def feedback(self, state):
            got.append(state)

    class Gone:
        def feedback(self, state):
            raise TimeoutError("no answer")

    fb = DeviceFeedback({"teleop": Page(), "teleop2": Gone(), "other": object()}, rate_hz=10, log=said.append)
    for k in range(50):  # 0.5 s at 100 Hz
        fb(k * 0.01, [_Arm()])
    assert 4 <= len(got) <= 6 and got[0] == {"arm_xyz": [0.1, 0.2, 0.3]}
    assert len(said) == 1 and "teleop2" in said[0] and list(fb.targets) == ["teleop"]
