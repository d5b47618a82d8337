"""`rio franka status / recover` (registered through the plugin's `rio_cli` hook) on a fake control box:
a reflex named, then cleared by libfranka's error recovery while a node holds it."""

from __future__ import annotations

import json

from rio_franka import fake
from rio_franka.arm.driver import FrankaArm

from rio.cli import main
from rio.testing import lifecycle


def test_status_and_recover_name_and_clear_a_reflex(fake_ip, capsys):
    with lifecycle(FrankaArm(ip=fake_ip, backend="fake", model="panda")) as arm:
        arm.cycle()
        fake.controller(fake_ip).inject("collision")
        assert arm.cycle()["fault_code"] == 3
        assert main(["franka", "status", "--ip", fake_ip, "--backend", "fake"]) == 0
        out = capsys.readouterr().out
        assert "collision" in out and "mode reflex" in out
        assert main(["franka", "status", "--ip", fake_ip, "--backend", "fake", "--json"]) == 0
        got = json.loads(capsys.readouterr().out)
        assert "collision" in got["fault"] and "reflex" in got["mode"].lower() and len(got["joints_rad"]) == 7
        assert main(["franka", "recover", "--ip", fake_ip, "--backend", "fake"]) == 0
        assert "cleared collision" in capsys.readouterr().out
        assert fake.controller(fake_ip).model.name == "panda"  # the CLI left the box as the node made it
        assert arm.clear_faults() == "cleared"
        s = arm.cycle()
        assert s["enabled"] and s["fault_code"] == 0
        assert main(["franka", "recover", "--ip", fake_ip, "--backend", "fake"]) == 0
        assert "nothing to clear" in capsys.readouterr().out


def test_an_unreachable_robot_is_one_line_and_exit_1(fake_ip, capsys):
    fake.controller(fake_ip).fci_active = False
    assert main(["franka", "recover", "--ip", fake_ip, "--backend", "fake"]) == 1
    assert "activate FCI" in capsys.readouterr().err
