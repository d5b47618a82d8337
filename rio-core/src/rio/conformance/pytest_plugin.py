"""rio-core's pytest plugin, loaded through the `pytest11` entry point `rio` in every pytest run of an
environment where rio-core is installed (disable with `-p no:rio`).

It only adds options:

- `--rio-middleware NAME`: run the middleware conformance kit (`rio.conformance.middleware`) against
  the registered middleware NAME, without a test file;
- `--rio-driver NAME` (with `--rio-driver-config JSON`, the station fields): run the driver conformance
  kit of NAME's kind (`rio.conformance.drivers`) against the registered driver NAME, e.g.
  `pytest --rio-driver so100.follower --rio-driver-config '{"port": "emulator"}'`, or on real hardware.

With test paths given, those run as usual; add `--pyargs rio.conformance.middleware` (or
`rio.conformance.drivers`) to run a kit with them. The kits' fixtures live on their test classes, so
nothing here needs them.

Kept cheap to import (standard library and pytest only): pytest imports it in every run.
"""

from __future__ import annotations

from pathlib import Path

import pytest

#: The module collected by `pytest --rio-middleware NAME` when no test path is given.
MIDDLEWARE_KIT = Path(__file__).with_name("middleware.py")
#: The module collected by `pytest --rio-driver NAME` when no test path is given.
DRIVER_KIT = Path(__file__).with_name("drivers.py")


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("rio", "RIO conformance kits")
    group.addoption(
        "--rio-middleware", dest="rio_middleware", metavar="NAME", default=None,
        help="run the middleware conformance kit against the registered middleware NAME "
             "(only the kit when no test path is given)",
    )
    group.addoption(
        "--rio-driver", dest="rio_driver", metavar="NAME", default=None,
        help="run the driver conformance kit of NAME's kind against the registered driver NAME "
             "(only the kit when no test path is given)",
    )
    group.addoption(
        "--rio-driver-config", dest="rio_driver_config", metavar="JSON", default=None,
        help='station fields of the --rio-driver node, as a JSON object, e.g. \'{"port": "/dev/ttyACM0"}\'',
    )


def pytest_configure(config: pytest.Config) -> None:
    if config.args_source is pytest.Config.ArgsSource.ARGS:
        return
    kits = [str(kit) for option, kit in (("rio_middleware", MIDDLEWARE_KIT), ("rio_driver", DRIVER_KIT))
            if config.getoption(option, None)]
    if kits:
        config.args = kits


def pytest_report_header(config: pytest.Config) -> list[str] | None:
    lines = []
    name = config.getoption("rio_middleware", None)
    if name:
        lines.append(f"rio: middleware conformance kit on '{name}'")
    driver = config.getoption("rio_driver", None)
    if driver:
        fields = config.getoption("rio_driver_config", None)
        lines.append(f"rio: driver conformance kit on '{driver}'" + (f" with {fields}" if fields else ""))
    return lines or None
