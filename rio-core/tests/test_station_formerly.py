"""A renamed station keeps its old name for one release (`Spec.formerly`), resolved in one place
(`find_station`): the old name loads the station with one log line naming the new one; a current name that
is also another station's former name stays the current station and says which one it named before;
`check_spec` refuses a malformed `formerly`."""

from __future__ import annotations

import logging
import types

import pytest

from rio.errors import ConfigError
from rio.plugins import Registry
from rio.plugins.hookspecs import hookimpl
from rio.plugins.specs import HOOK_KINDS, Spec, check_spec
from rio.station import load as station_load
from rio.station.load import find_station, load_station

STATION = '''name = "{name}"
rate_hz = 30

[middleware]
name = "thread"

[components.arm]
driver = "rio.fake_arm"
'''


@pytest.fixture
def reg(tmp_path, monkeypatch):
    """Two stations swapped the way xarm7 did: the physics one took a new name ('acme-sim', formerly
    'acme-emulator') and the one without physics took its old name ('acme-emulator', formerly 'acme-virtual')."""
    monkeypatch.setattr(station_load, "_noticed", set())  # the notice is once per process: start afresh
    paths = {}
    for name in ("acme-sim", "acme-emulator"):
        paths[name] = tmp_path / f"{name}.toml"
        paths[name].write_text(STATION.format(name=name))
    mod = types.ModuleType("acme_stations")

    @hookimpl
    def rio_stations():
        return [Spec("acme-sim", "station", str(paths["acme-sim"]), "the acme arm with physics",
                     formerly=("acme-emulator",)),
                Spec("acme-emulator", "station", str(paths["acme-emulator"]), "the acme arm without physics",
                     formerly=("acme-virtual",))]

    mod.rio_stations = rio_stations
    registry = Registry(load_entry_points=False)  # rio-core and these two stations only
    assert registry.register(mod, name="acme", dist="acme-stations")
    return registry, paths


def lines(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == "rio.station"]


def test_an_old_name_loads_the_renamed_station_and_says_so_once(reg, caplog):
    registry, paths = reg
    with caplog.at_level(logging.WARNING, logger="rio.station"):
        assert find_station("acme-virtual", registry) == str(paths["acme-emulator"])
        st = load_station("acme-virtual", registry=registry)  # finds it again: no second line
        find_station("acme-virtual", registry)
    assert st.name == "acme-emulator"
    assert lines(caplog) == ["station 'acme-virtual' is now 'acme-emulator'; the old name works until the next "
                             "release"]


def test_a_current_name_wins_over_a_former_one_and_says_what_it_named_before(reg, caplog):
    registry, paths = reg
    with caplog.at_level(logging.WARNING, logger="rio.station"):
        assert find_station("acme-emulator", registry) == str(paths["acme-emulator"])
        assert load_station("acme-emulator", registry=registry).name == "acme-emulator"
    assert lines(caplog) == ["station 'acme-emulator' now names the acme arm without physics; the station it "
                             "named until this release is 'acme-sim' (the acme arm with physics)"]


def test_a_current_name_that_was_nobody_else_s_says_nothing(reg, caplog):
    registry, paths = reg
    with caplog.at_level(logging.WARNING, logger="rio.station"):
        assert find_station("acme-sim", registry) == str(paths["acme-sim"])
    assert lines(caplog) == []


def test_an_unknown_name_is_still_an_error(reg):
    registry, _ = reg
    with pytest.raises(ConfigError, match="unknown station 'acme-virtal'"):
        find_station("acme-virtal", registry)


@pytest.mark.parametrize(("formerly", "why"), [
    (["acme-old"], "formerly must be a tuple of old names"),
    ("acme-old", "formerly must be a tuple of old names"),  # a bare string would be its letters
    (("acme old",), "formerly: 'acme old' is not a valid name"),
    ((3,), "formerly: 3 is not a valid name"),
    (("",), "formerly: '' is not a valid name"),
    (("acme-new",), "formerly: 'acme-new' is its current name"),
])
def test_check_spec_refuses_a_malformed_formerly(formerly, why):
    spec = Spec("acme-new", "station", "/abs/acme-new.toml", "a station", formerly=formerly)
    assert why in check_spec(spec, HOOK_KINDS["rio_stations"])


def test_check_spec_accepts_old_names_and_none():
    for formerly in ((), ("acme-old",), ("acme-old", "acme.older_1")):
        spec = Spec("acme-new", "station", "/abs/acme-new.toml", "a station", formerly=formerly)
        assert check_spec(spec, HOOK_KINDS["rio_stations"]) is None
