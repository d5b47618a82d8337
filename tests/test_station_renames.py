"""The stand-ins got one word each (fake, emulator, sim): every renamed packaged station still loads by its old
name for one release, saying so once; `xarm7-emulator` (the old name of xarm7-sim, now the emulator without
physics) says which station it named before; `rio stations list` shows the old names; and the renamed bus
emulator's old config values, field and command still work, each with its one line.

names_rewrite: skip-file (it names the old names on purpose: the rename script leaves such files alone)
"""

from __future__ import annotations

import json
import logging

import pytest

from rio.cli import main
from rio.config import accept_renamed
from rio.plugins import get_registry
from rio.station import load as station_load
from rio.station.load import find_station, load_station

#: old name -> new name, as renamed (the issue "Core v3", item 6).
RENAMES = {
    "t1-emulator": "t1-fake",
    "cameras-virtual": "cameras-fake",
    "fr3-virtual": "fr3-fake",
    "gen3-virtual": "gen3-fake",
    "realsense-virtual": "realsense-fake",
    "robotiq-virtual": "robotiq-emulator",
    "so100-virtual": "so100-emulator",
    "so100-bimanual-virtual": "so100-bimanual-emulator",
    "gello-xarm7-virtual": "gello-xarm7-fake",
    "gello-bimanual-virtual": "gello-bimanual-fake",
    "xarm7-virtual": "xarm7-emulator",
    "lite6-virtual": "lite6-emulator",
    "ur5e-virtual": "ur5e-emulator",
    "g1-bridge": "g1-sim",
    "g1-bridge-hands": "g1-sim-hands",
    "g1-bridge-inspire": "g1-sim-inspire",
    "g1-bridge-floating": "g1-sim-floating",
    "lekiwi-virtual": "lekiwi-emulator",  # added by main's LeKiwi merge with the old word, renamed the same way
}


@pytest.fixture(autouse=True)
def fresh_notices(monkeypatch):
    monkeypatch.setattr(station_load, "_noticed", set())  # the notices are once per process


def station_lines(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == "rio.station"]


@pytest.mark.parametrize(("old", "new"), sorted(RENAMES.items()))
def test_an_old_station_name_loads_the_renamed_station_and_says_so_once(old, new, caplog):
    with caplog.at_level(logging.WARNING, logger="rio.station"):
        st = load_station(old)
        assert find_station(old) == get_registry().find("rio_stations", new).target  # the same packaged file
        load_station(old)
    assert st.name == new
    assert station_lines(caplog) == [f"station '{old}' is now '{new}'; the old name works until the next release"]


def test_xarm7_emulator_is_the_emulator_now_and_names_the_sim(caplog):
    """The one collision: `xarm7-emulator` was the physics station (now xarm7-sim) and is the new name of the
    emulator without physics (formerly xarm7-virtual). The current name wins, and says so."""
    with caplog.at_level(logging.WARNING, logger="rio.station"):
        emulator = load_station("xarm7-emulator")
        load_station("xarm7-emulator")
    assert emulator.name == "xarm7-emulator"
    assert "world_sensor" not in emulator.components  # no rio-sim world behind it
    assert "world_sensor" in load_station("xarm7-sim").components
    (line,) = station_lines(caplog)
    assert line.startswith("station 'xarm7-emulator' now names xArm 7 + xArm Gripper through the real SDK against "
                           "the emulator's model arm (no physics")
    assert "the station it named until this release is 'xarm7-sim' (" in line and "rio-sim physics" in line


def test_stations_list_shows_the_old_names(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "400")  # the table on one line per station
    assert main(["stations", "list", "--json"]) == 0
    listed = {s["name"]: s["formerly"] for s in json.loads(capsys.readouterr().out)}
    for old, new in RENAMES.items():
        assert old in listed[new], (new, listed[new])
    assert listed["xarm7-sim"] == ["xarm7-emulator"]
    assert main(["stations", "list"]) == 0
    assert "formerly so100-virtual" in capsys.readouterr().out


def test_old_bus_emulator_values_and_field_still_work(caplog):
    """port = "virtual" (a ServoBus) and ip = "virtual" (the Robotiq URCap) are "emulator" now, and
    virtual_motion is emulator_motion: a station file with the old ones validates as the new."""
    from rio_robotiq.robotiq.driver import RobotiqUrcapGripper
    from rio_so100.leader.driver import So100Leader
    from rio_teleop.gello.driver import GelloLeader

    with caplog.at_level(logging.WARNING, logger="rio.config"):
        leader = So100Leader.Config.model_validate({"port": "virtual", "virtual_motion": "wave"})
        gello = GelloLeader.Config.model_validate({"port": "virtual", "layout": "xarm7", "virtual_motion": "wave"})
        urcap = RobotiqUrcapGripper.Config.model_validate({"ip": "virtual"})
    assert (leader.port, leader.emulator_motion) == ("emulator", "wave")
    assert (gello.port, gello.emulator_motion) == ("emulator", "wave")
    assert urcap.ip == "emulator"
    assert "port = 'virtual' is now 'emulator'" in caplog.text
    assert "'virtual_motion' is now 'emulator_motion'" in caplog.text
    assert "ip = 'virtual' is now 'emulator'" in caplog.text
    from rio.interfaces.devices import ServoBus

    assert accept_renamed(ServoBus, {"port": "/dev/ttyACM0"}) == {"port": "/dev/ttyACM0"}  # a real port is kept


def test_the_old_bus_command_is_a_hidden_alias(capsys):
    assert main(["so100", "virtual-bus", "--seconds", "0.2"]) == 0
    out = capsys.readouterr()
    assert out.out.startswith("/dev/pts/")
    assert "'virtual-bus' is now 'emulator' (the old name works until the next release)" in out.err
    assert main(["so100", "--help"]) == 0
    assert "virtual-bus" not in capsys.readouterr().out
