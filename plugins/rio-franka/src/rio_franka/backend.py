"""The seam between the drivers and franky: where a node gets its robot and gripper objects.

`backend = "franky"` connects franky (libfranka) to the robot; `"fake"` and `"sim"` / `"sim:ARM@WORLD"`
hand out `fake.FakeRobot` / `fake.FakeGripper` objects with the same surface (see `fake.py` for why
libfranka's link itself is not emulated). A failed connection comes back as a `FrankaSetupError` that
says what to change (versions, FCI, network, real-time) whichever backend raised it.
"""

from __future__ import annotations

from typing import Any

from .faults import FrankaError, setup_error


def versions() -> str:
    """The installed franky and the libfranka it bundles, for error messages and `rio franka status`."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        franky = version("franky-control")
    except PackageNotFoundError:
        return "franky-control not installed"
    import glob
    import os

    import franky as _f

    libs = glob.glob(os.path.join(os.path.dirname(_f.__file__), "..", "franky_control.libs", "libfranka-*.so.*"))
    lib = os.path.basename(libs[0]).split(".so.")[-1] if libs else "?"
    return f"franky-control {franky} with libfranka {lib}"


def _sim(backend: str) -> tuple[str, str] | None:
    if backend == "fake":
        return None
    from rio_sim.world_arm import parse_sim_target

    target = parse_sim_target(backend)
    if target is None:
        raise ValueError(f"backend '{backend}': use 'franky', 'fake', 'sim' or 'sim:ARM@WORLD'")
    return target


def _connect(ip: str, make) -> Any:
    try:
        return make()
    except Exception as e:  # franky's exceptions are not importable without franky: judge by name and text
        err = setup_error(ip, e, versions())
        if err is not None:
            raise err from e
        raise FrankaError(ip, "connect", f"{type(e).__name__}: {e}") from e


def connect_robot(ip: str, backend: str, model: str | None, relative_dynamics_factor: float,
                  realtime: bool = True) -> Any:
    """A franky `Robot` (or the fake's) connected to `ip` (`model` None: the fake box's as it is)."""
    if backend == "franky":
        import franky

        rt = franky.RealtimeConfig.Enforce if realtime else franky.RealtimeConfig.Ignore
        return _connect(ip, lambda: franky.Robot(ip, relative_dynamics_factor=relative_dynamics_factor,
                                                 realtime_config=rt))
    from . import fake

    ctl = fake.controller(ip, model, _sim(backend))
    return _connect(ip, lambda: fake.FakeRobot(ctl, relative_dynamics_factor))


def connect_gripper(ip: str, backend: str) -> Any:
    """A franky `Gripper` (or the fake's) on the robot at `ip`."""
    if backend == "franky":
        import franky

        return _connect(ip, lambda: franky.Gripper(ip))
    from . import fake

    ctl = fake.controller(ip, None, _sim(backend))
    return _connect(ip, lambda: fake.FakeGripper(ctl))
