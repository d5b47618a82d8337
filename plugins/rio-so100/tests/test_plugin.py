"""The plugin as a user meets it: registered drivers and stations, `rio so100 ...` commands, and no
Feetech SDK imported until a bus is opened."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from rio.cli import main
from rio.embodiments.infer import infer_embodiment
from rio.plugins import Registry
from rio.station.load import load_station

DRIVERS = {"so100.follower": "arm", "so100.gripper": "gripper", "so100.leader": "teleop",
           "so101.follower": "arm", "so101.gripper": "gripper", "so101.leader": "teleop",
           "lekiwi.base": "base"}
STATIONS = ["so100-emulator", "so100-bimanual-emulator", "so100-sim", "so100", "so100-bimanual", "so101",
            "so101-bimanual"]
LEKIWI_STATIONS = ["lekiwi", "lekiwi-emulator", "lekiwi-sim"]


def test_drivers_and_stations_are_registered():
    reg = Registry()
    assert not [p for p in reg.problems if p.plugin in ("so100", "rio-so100")], reg.problems
    drivers = {s.name: s for s in reg.specs("rio_drivers") if s.plugin == "rio-so100"}
    assert {n: s.kind for n, s in drivers.items()} == DRIVERS
    for spec in drivers.values():
        assert spec.config_model().model_fields["port"].is_required()
        if spec.kind == "base":
            continue
        assert spec.load().__name__.startswith("So100")  # one class per device; SO-101 is a preset
        assert spec.preset == {"model": spec.name.split(".")[0]}
    stations = sorted(s.name for s in reg.specs("rio_stations") if s.plugin == "rio-so100")
    assert stations == sorted(STATIONS + LEKIWI_STATIONS)


@pytest.mark.parametrize("name", LEKIWI_STATIONS)
def test_lekiwi_stations_are_mobile_manipulators_on_one_bus(name):
    st = load_station(name)
    base, arm = st.components["base"].driver, st.components["arm"].driver
    assert (base, arm) == (("sim.base", "sim.arm") if name == "lekiwi-sim" else ("lekiwi.base", "so101.follower"))
    if name != "lekiwi-sim":
        ports = {st.components[r].config.port for r in ("arm", "gripper", "base")}
        assert len(ports) == 1  # arm, jaw and wheels share LeKiwi's one bus
    assert infer_embodiment(st.roles()).name == "mobile_manipulator"


@pytest.mark.parametrize("name", STATIONS)
def test_packaged_stations_validate(name):
    st = load_station(name)
    assert st.components["arm"].driver.endswith(".follower") and st.components["teleop"].driver.endswith(".leader")
    if "bimanual" in name:
        assert {"arm2", "gripper2", "teleop2"} <= st.roles()
        assert st.components["arm"].config.calibration == "left"


def test_listing_imports_no_sdk():
    code = ("import sys; from rio.plugins import Registry; r = Registry(); "
            "[s.config_model() for s in r.specs('rio_drivers')]; "
            "import rio_so100.follower.driver, rio_so100.leader.driver; print('scservo_sdk' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "False", out.stderr


def test_emulator_command_prints_a_port(capsys):
    assert main(["so100", "emulator", "--seconds", "0.2"]) == 0
    assert capsys.readouterr().out.startswith("/dev/pts/")


def test_calibrate_command_on_an_emulated_arm(capsys, config_home):
    assert main(["so100", "calibrate", "--port", "emulator", "--device", "leader", "--model", "so101"]) == 0
    out = capsys.readouterr().out
    saved = config_home / "rio" / "calibration" / "so101-leader" / "emulator-demo.json"
    assert f"saved {saved}" in out and saved.is_file()
    assert "wrist_roll" in out and "rad" in out


def test_scan_and_torque_commands(vbus, capsys):
    assert main(["so100", "scan", "--port", vbus.port, "--max-id", "7"]) == 0
    out = capsys.readouterr().out
    assert "id 6: model 777, position 2048, 7.4 V" in out and "id 7" not in out
    assert main(["so100", "scan", "--port", vbus.port, "--max-id", "7", "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert [s["id"] for s in got] == [1, 2, 3, 4, 5, 6] and got[5]["voltage_v"] == 7.4
    assert main(["so100", "torque", "on", "--port", vbus.port, "--ids", "1,2"]) == 0
    assert vbus.servo(1).torque_on and vbus.servo(2).torque_on and not vbus.servo(3).torque_on
