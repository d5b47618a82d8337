"""The plugin as a user meets it: registered drivers and stations, the `rio ufactory ...` recovery
commands against an emulated controller, clear config errors, and no SDK imported to list drivers."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import pytest
from pydantic import ValidationError
from rio_ufactory.arm.driver import XArm
from rio_ufactory.models import ARMS

from rio.cli import main
from rio.plugins import Registry
from rio.station.load import load_station

STATIONS = ["xarm7-robotiq", "xarm7-sim", "xarm7-emulator", "lite6-emulator"]


def test_drivers_and_stations_are_registered():
    reg = Registry()
    assert not [p for p in reg.problems if p.plugin in ("ufactory", "rio-ufactory")], reg.problems
    drivers = {s.name: s for s in reg.specs("rio_drivers") if s.plugin == "rio-ufactory"}
    for model in ARMS:
        spec = drivers[f"ufactory.{model}"]
        assert spec.kind == "arm" and spec.preset == {"model": model}
        assert spec.config_model().model_fields["ip"].is_required()
    assert {n for n, s in drivers.items() if s.kind == "gripper"} >= {
        "ufactory.gripper", "ufactory.gripper_g2", "ufactory.bio_gripper", "ufactory.lite6_gripper",
        "ufactory.vacuum", "ufactory.robotiq", "ufactory.robotiq_2f140"}
    assert sorted(s.name for s in reg.specs("rio_stations") if s.plugin == "rio-ufactory") == sorted(STATIONS)


@pytest.mark.parametrize("name", STATIONS)
def test_packaged_stations_validate(name):
    st = load_station(name)
    arm, grip = st.components["arm"], st.components["gripper"]
    assert arm.driver.startswith("ufactory.") and grip.driver.startswith("ufactory.")
    assert arm.config.ip == grip.config.ip
    if "emulator_sensor" in st.components:
        assert st.components["emulator_sensor"].config.ip == arm.config.ip


def test_config_errors_name_the_field():
    with pytest.raises(ValidationError, match="not an IPv4 address"):
        XArm(ip="/dev/ttyUSB0")
    with pytest.raises(ValidationError, match="model"):
        XArm(ip="192.168.1.185", model="xarm9")
    with pytest.raises(ValueError, match="joint_limits has 6 entries"):
        XArm(ip="192.168.1.185", model="xarm7", joint_limits=[[-1, 1]] * 6)


def test_listing_imports_no_sdk():
    code = ("import sys; from rio.plugins import Registry; r = Registry(); "
            "[s.config_model() for s in r.specs('rio_drivers')]; "
            "import rio_ufactory.arm.driver, rio_ufactory.gripper.xarm_gripper; print('xarm' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "False", out.stderr


def cli_args(emu) -> list[str]:
    return ["--ip", emu.host]


def test_status_clear_errors_and_enable_commands(make_emulator, capsys):
    emu = make_emulator("xarm6")
    assert main(["ufactory", "status", *cli_args(emu)]) == 0
    out = capsys.readouterr().out
    assert "xArm 6 (axis 6, type 6)" in out and "no fault" in out
    emu.inject_fault("collision")
    assert main(["ufactory", "status", *cli_args(emu)]) == 0
    assert "C31 collision" in capsys.readouterr().out
    assert main(["ufactory", "status", *cli_args(emu), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)  # only the JSON: the SDK's chatter goes to stderr
    assert got["axis"] == 6 and "C31" in got["fault"] and len(got["joints_rad"]) == 6
    assert main(["ufactory", "clear-errors", *cli_args(emu)]) == 0
    assert "cleared C31 collision" in capsys.readouterr().out and emu.error_code == 0
    assert main(["ufactory", "enable", *cli_args(emu)]) == 0
    assert "enabled, servo mode" in capsys.readouterr().out
    assert emu.enabled and emu.mode == 1 and emu.state in (1, 2)


def test_commands_say_what_is_wrong_without_a_controller(capsys):
    from rio_ufactory.loopback import free_loopback

    assert main(["ufactory", "status", "--ip", free_loopback()]) == 1
    assert "no xArm controller answers on TCP 502" in capsys.readouterr().err


def test_emulator_command_serves_a_controller_until_interrupted():
    import signal

    from rio_ufactory.connection import XArmConnection
    from rio_ufactory.loopback import PORT_502_HINT, can_listen_on_502, free_loopback

    if not can_listen_on_502():
        pytest.skip(PORT_502_HINT)
    host = free_loopback()
    proc = subprocess.Popen([sys.executable, "-m", "rio", "ufactory", "emulator", "--model", "lite6", "--ip", host,
                             "--gripper", "lite6"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        first = proc.stdout.readline()
        assert f"Lite 6 controller emulator listening on {host}" in first, first
        ctl = XArmConnection.acquire(host, model="lite6")
        assert (ctl.api.axis, ctl.api.device_type) == (6, 9)
        ctl.release()
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            out, _ = proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGUSR1)  # `rio` prints every thread's stack: where it is stuck
            time.sleep(1.0)
            proc.kill()  # else it outlives the test, serving on its address (seen: 13 min after a failed run)
            out, _ = proc.communicate()
            raise AssertionError(f"the emulator did not stop within 30 s of SIGINT; its threads:\n"
                                 f"{out[-12000:]}") from None
    assert proc.returncode == 0, out
