"""rio-ati's plugin module (entry point group `rio`): the driver, the emulator node and a packaged station.
Specs only: nothing here opens a socket or imports numpy."""

from __future__ import annotations

from rio.plugins.hookspecs import hookimpl
from rio.plugins.specs import Spec

_P = "rio_ati"


@hookimpl
def rio_drivers() -> list[Spec]:
    return [
        Spec("ati.netft", "sensor", f"{_P}.driver:NetFTSensor",
             "ATI Net F/T (or Axia80) force/torque sensor over RDT (UDP 49152), calibration from its web page"),
        Spec("ati.emulator", "sensor", f"{_P}.emulator_node:EmulatorNode",
             "an emulated Net F/T box on a loopback address (RDT over UDP, netftapi2.xml over HTTP)"),
    ]


@hookimpl
def rio_stations() -> list[Spec]:
    return [Spec("ati-emulator", "station", f"{_P}:stations/ati-emulator.toml",
                 "a fake arm with a wrist Net F/T, served by an emulated box on 127.0.0.12 (no hardware)")]
