"""rio-core's pytest plugin, loaded through the `pytest11` entry point `rio` in every pytest run of an
environment where rio-core is installed (disable with `-p no:rio`).

It only adds the `--rio-middleware NAME` option: `pytest --rio-middleware NAME` runs the middleware
conformance kit (`rio.conformance.middleware`) against the registered middleware NAME, without a test
file. With test paths given, those run as usual; add `--pyargs rio.conformance.middleware` to run the
kit with them. The kit's fixtures live on its test class, so nothing here needs them.

Kept cheap to import (standard library and pytest only): pytest imports it in every run.
"""

from __future__ import annotations

from pathlib import Path

import pytest

#: The module collected by `pytest --rio-middleware NAME` when no test path is given.
MIDDLEWARE_KIT = Path(__file__).with_name("middleware.py")


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("rio", "RIO conformance kits")
    group.addoption(
        "--rio-middleware", dest="rio_middleware", metavar="NAME", default=None,
        help="run the middleware conformance kit against the registered middleware NAME "
             "(only the kit when no test path is given)",
    )


def pytest_configure(config: pytest.Config) -> None:
    if config.getoption("rio_middleware", None) and config.args_source is not pytest.Config.ArgsSource.ARGS:
        config.args = [str(MIDDLEWARE_KIT)]


def pytest_report_header(config: pytest.Config) -> str | None:
    name = config.getoption("rio_middleware", None)
    return f"rio: middleware conformance kit on '{name}'" if name else None
