"""Shared fixtures for rio-core tests. The process helpers live in the shipped conformance kit
(`rio.conformance.process`) and are re-exported here for the test modules that import them."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from rio.conformance.process import _is_resource_tracker, child_pids, shm_entries

MIDDLEWARES = ["thread", "shm", "zmq", "zenoh", "portal"]

__all__ = ["MIDDLEWARES", "child_pids", "shm_entries", "_is_resource_tracker", "run_rio", "kit_outcomes"]


@pytest.fixture(params=MIDDLEWARES)
def mw(request: pytest.FixtureRequest) -> str:
    return request.param


def run_rio(args, dist_path=None, **env):
    """`python -m rio ARGS` in a subprocess, with `dist_path` (plugin distributions written by
    `rio.testing.write_plugin_dist`) on its PYTHONPATH and `env` on top of this environment."""
    full_env = {**os.environ, **env}
    if dist_path is not None:
        full_env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(dist_path), full_env.get("PYTHONPATH")]))
    return subprocess.run([sys.executable, "-m", "rio", *args], capture_output=True, text=True, env=full_env,
                          timeout=60)


@pytest.fixture
def registry(monkeypatch):
    """An isolated registry (core only) that the CLI will use; tests register inline plugins into it."""
    from rio.plugins import Registry
    from rio.plugins import registry as plugins

    reg = Registry(load_entry_points=False)
    monkeypatch.setattr(plugins, "_REGISTRY", reg)
    return reg


def kit_outcomes(reprec: pytest.HookRecorder) -> dict[str, dict[str, str]]:
    """A pytester run of a conformance kit as {class name: {case: outcome}} ("passed", "failed",
    "skipped", or "error" for a failure outside the test body), with each failure's text as
    "<case> text": how the kit tests prove that a broken implementation fails the right cases."""
    out: dict[str, dict[str, str]] = {}
    for rep in reprec.getreports("pytest_runtest_logreport"):
        if rep.when != "call" and not (rep.failed or rep.skipped):
            continue
        cls, case = rep.nodeid.split("::")[-2:]
        out.setdefault(cls, {})[case] = "error" if rep.failed and rep.when != "call" else rep.outcome
        if rep.failed:
            out[cls][f"{case} text"] = rep.longreprtext
    return out
