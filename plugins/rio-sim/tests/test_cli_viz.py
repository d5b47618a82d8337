"""`rio teleop` as a command, and `--viz` to rerun."""

from __future__ import annotations

import pytest

from rio.cli import main
from rio.testing import block_import
from rio.workflows.teleop import run_teleop


def test_rio_teleop_command_runs_and_prints_a_summary(capsys):
    rc = main(["teleop", "sim-so100", "--teleop", "scripted", "--duration", "1.5", "-m", "thread"])
    out = capsys.readouterr()
    assert rc == 0, out.err
    assert "teleop on 'sim-so100' with teleop.scripted: duration reached" in out.out
    assert "arm: tool (+0.200, +0.000, +0.100)" in out.out
    assert "teleop running" in out.err


def test_rio_teleop_unknown_device_lists_the_registered_ones(capsys):
    rc = main(["teleop", "sim-so100", "--teleop", "joystick", "-m", "thread"])
    err = capsys.readouterr().err
    assert rc == 1 and "teleop.keyboard" in err and "teleop.scripted" in err


def test_viz_saves_a_rerun_recording(tmp_path):
    pytest.importorskip("rerun")
    path = tmp_path / "run.rrd"
    summary = run_teleop("sim-so100", "scripted", middleware="thread", duration=1.0, viz=str(path), log=None)
    assert summary.details["viz"] == str(path)
    assert path.stat().st_size > 50_000  # camera frames, joints and poses were logged


def test_viz_without_rerun_runs_on(monkeypatch):
    block_import(monkeypatch, "rerun")
    said = []
    summary = run_teleop("sim-so100", "scripted", middleware="thread", duration=0.5, viz=True, log=said.append)
    assert "viz" not in summary.details and summary.ticks > 5
    assert any("rerun-sdk is not installed" in s for s in said)
