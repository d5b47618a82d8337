"""The plugin as a user meets it: registered drivers and stations, clear config errors, the exact
install line when kortex_api is missing (its import is made to fail here), and no kortex import to
list drivers."""

from __future__ import annotations

import subprocess
import sys

import pytest
from pydantic import ValidationError
from rio_kinova.arm.driver import KinovaArm
from rio_kinova.models import ARMS

from rio.plugins import Registry
from rio.station.load import load_station
from rio.testing import lifecycle

STATIONS = ["gen3-fake", "gen3-robotiq", "gen3-sim"]


def test_drivers_stations_and_requirement_are_registered():
    reg = Registry()
    assert not [p for p in reg.problems if p.plugin in ("kinova", "rio-kinova")], reg.problems
    drivers = {s.name: s for s in reg.specs("rio_drivers") if s.plugin == "rio-kinova"}
    for model in ARMS:
        assert drivers[f"kinova.{model}"].kind == "arm" and drivers[f"kinova.{model}"].preset == {"model": model}
    assert drivers["kinova.robotiq_2f85"].kind == "gripper"
    assert sorted(s.name for s in reg.specs("rio_stations") if s.plugin == "rio-kinova") == STATIONS
    from rio_kinova.plugin import rio_requirements

    req = rio_requirements()[0]  # then mink, for [ik]
    assert "kortex_api-2.6.0.post3-py3-none-any.whl" in req.install and "protobuf" in req.install


@pytest.mark.parametrize("name", STATIONS)
def test_packaged_stations_validate(name):
    st = load_station(name)
    arm, grip = st.components["arm"], st.components["gripper"]
    assert arm.driver == "kinova.gen3" and grip.driver == "kinova.robotiq_2f85"
    assert (arm.config.ip, arm.config.backend) == (grip.config.ip, grip.config.backend)


def test_config_errors_name_the_field():
    with pytest.raises(ValidationError, match="not an IPv4 address"):
        KinovaArm(ip="gen3.local")
    with pytest.raises(ValidationError, match="backend 'emulator'"):
        KinovaArm(backend="emulator")
    with pytest.raises(ValidationError, match="model"):
        KinovaArm(model="gen2")
    with pytest.raises(ValueError, match="needs the base's high-level control"):
        KinovaArm(low_level=True, eef_control="controller")


def test_missing_kortex_says_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "kortex_api", None)  # `import kortex_api...` raises ImportError
    with pytest.raises(ImportError) as e:
        with lifecycle(KinovaArm(ip="192.168.1.10")):
            pass
    text = str(e.value)
    assert "kortex_api-2.6.0.post3-py3-none-any.whl" in text and "github.com/Kinovarobotics/kortex/releases" in text
    assert "pip install ./kortex_api-2.6.0.post3-py3-none-any.whl 'protobuf==3.20.0'" in text


def test_listing_imports_no_kortex():
    code = ("import sys; from rio.plugins import Registry; r = Registry(); "
            "[s.config_model() for s in r.specs('rio_drivers')]; "
            "import rio_kinova.arm.driver, rio_kinova.gripper.robotiq; print('kortex_api' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "False", out.stderr
