"""The plugin as a user meets it: the driver and emulator registered, listing imports no socket code, and
the packaged station (the real driver against the emulated box) teleoperates and records the wrench."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from rio.plugins import Registry
from rio.station.load import load_station


def test_drivers_and_station_are_registered():
    from rio_ati.driver import NetFTSensor
    from rio_ati.emulator_node import EmulatorNode

    reg = Registry()
    assert not [p for p in reg.problems if "ati" in str(p.plugin)], reg.problems
    drivers = {s.name: s for s in reg.specs("rio_drivers") if s.plugin == "rio-ati"}
    assert {n: s.kind for n, s in drivers.items()} == {"ati.netft": "sensor", "ati.emulator": "sensor"}
    assert drivers["ati.netft"].load() is NetFTSensor and drivers["ati.emulator"].load() is EmulatorNode
    assert [s.name for s in reg.specs("rio_stations") if s.plugin == "rio-ati"] == ["ati-emulator"]
    cfg = drivers["ati.netft"].validate({"ip": "192.168.1.1"})
    assert (cfg.rdt_port, cfg.http_port, cfg.rate_hz, cfg.device_tare) == (49152, 80, 1000.0, True)


def test_listing_imports_no_driver_module():
    code = ("import sys; from rio.plugins import Registry; Registry().specs('rio_drivers'); "
            "print(any(m.startswith('rio_ati.') and m != 'rio_ati.plugin' for m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "False", out.stderr


def test_the_packaged_station_records_the_wrench(tmp_path):
    from rio.recording import Dataset
    from rio.workflows.teleop import run_teleop

    st = load_station("ati-emulator")
    assert st.components["ft_sensor"].driver == "ati.netft"
    script = {"script": "moves", "moves": [[0, 0, -0.02, 1.0, 1.0]]}
    summary = run_teleop("ati-emulator", "scripted", device_config=script, duration=10, log=None,
                         record=str(tmp_path / "ds"))
    assert summary.reason == "the device finished", summary.reason
    assert summary.node_rates_hz.get("ft", 0) > 0, summary.node_rates_hz  # ~400-1000; a loaded machine less
    ep = Dataset(tmp_path / "ds").episode(0)
    force, torque = ep.column("meta.sensors.ft.force"), ep.column("meta.sensors.ft.torque")
    assert force.shape == (ep.length, 3) and torque.shape == (ep.length, 3)
    # the emulator's default load: 0.5 kg hanging from the cell, 0.05 N m about y; noise 0.02
    assert np.allclose(force.mean(axis=0), [0.0, 0.0, -4.9], atol=0.02)
    assert np.allclose(torque.mean(axis=0), [0.0, 0.05, 0.0], atol=0.02)
