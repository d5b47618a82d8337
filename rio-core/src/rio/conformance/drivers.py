"""Driver conformance kit: the contract cases of each driver kind, as inheritable test classes.

    from contextlib import contextmanager
    from rio.conformance.drivers import ArmConformance

    class TestAcmeArm(ArmConformance):
        driver = "acme.arm"                  # registered name, 'module:Class', or the node class
        config = {"port": "emulator"}        # station fields

        @contextmanager                      # optional: start the emulator, yield config overrides
        def emulator(self):
            with AcmeEmulator() as emu:
                yield {"port": emu.port}

        bad_config = {"port": "/dev/nope"}   # optional: a config whose open() must fail
        on_stale = "damp"                    # optional: what a silent stream gets, "hold" or "damp"
                                             # (default: what the node's damping guard says, `node.safety`, else "hold")

Base classes (none named `Test*`, so importing one collects nothing): `ArmConformance`,
`GripperConformance`, `HandConformance`, `HumanoidConformance`, `CameraConformance`,
`TeleopConformance`, `BaseConformance` (mobile bases, `rio.conformance.mobile`) and `SensorConformance` (any
node: the cases every driver passes).

The cases check public behaviour only. Most run the node in the test's thread with
`rio.testing.lifecycle()` and tick `cycle()` at the node's rate, as the runtime does; the goals

the kind asks the driver to write are recorded by wrapping the driver's `write_joints` /
`write_width` on the instance, so step and hold checks are exact and need no physics. A few cases go
through the runtime (`NodeRunner`, `ServerManager` on the thread middleware). Every failure names the
contract rule that was broken and what was seen. Tolerances are outcomes, never wall-clock speed, so
they hold on a loaded machine; emulators with dynamics of their own may need `tracking_tol` raised.

The emulator hook is entered once per case (a fresh device each time), around everything the case
builds. Without a file: `pytest --rio-driver NAME [--rio-driver-config JSON]` runs the kit of NAME's
kind (see `rio.conformance.pytest_plugin`); docs/conformance.md has the table of cases.
"""
from __future__ import annotations

from rio.conformance.commandable import ArmConformance, GripperConformance, HandConformance, HumanoidConformance
from rio.conformance.driver_base import DriverConformance, SensorConformance
from rio.conformance.mobile import BaseConformance
from rio.conformance.sensing import CameraConformance, TeleopConformance, WrenchConformance

__all__ = ["DriverConformance", "SensorConformance", "ArmConformance", "GripperConformance", "HandConformance",
           "HumanoidConformance", "CameraConformance", "TeleopConformance", "BaseConformance", "WrenchConformance"]


# -- `pytest --rio-driver NAME`: the kit of NAME's kind, collected where this module is ------------------
class TestSelectedArm(ArmConformance):
    driver = None


class TestSelectedGripper(GripperConformance):
    driver = None


class TestSelectedHand(HandConformance):
    driver = None


class TestSelectedHumanoid(HumanoidConformance):
    driver = None


class TestSelectedCamera(CameraConformance):
    driver = None


class TestSelectedTeleop(TeleopConformance):
    driver = None


class TestSelectedBase(BaseConformance):
    driver = None


class TestSelectedSensor(SensorConformance):
    driver = None

