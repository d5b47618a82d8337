"""The sim drivers pass the driver conformance kit of their kind. Each case runs against a fresh
`sim.world` (a thread of this process), which the emulator hook starts and names."""

from __future__ import annotations

import uuid
from contextlib import contextmanager

from rio_sim.world import SimWorld

from rio import ServerManager, serve
from rio.conformance.drivers import (
    ArmConformance,
    BaseConformance,
    CameraConformance,
    GripperConformance,
    SensorConformance,
    WrenchConformance,
)


class InSimWorld:
    """Emulator hook: a `sim.world` of the so100 scene for the node under test to attach to."""

    scene = "so100"

    @contextmanager
    def emulator(self):
        world = f"kit-{uuid.uuid4().hex[:8]}"
        with ServerManager("thread", [serve(SimWorld, name=f"{world}-world", world=world, scene=self.scene)],
                           station=world):
            yield {"world": world}


class TestSimArm(InSimWorld, ArmConformance):
    driver = "sim.arm"
    bad_config = {"arm": "no_such_arm"}


class TestSimGripper(InSimWorld, GripperConformance):
    driver = "sim.gripper"
    bad_config = {"arm": "no_such_arm"}


class TestSimBase(InSimWorld, BaseConformance):
    driver = "sim.base"
    scene = "lekiwi"
    bad_config = {"base": "no_such_base"}
    tracking_tol = 0.05  # the velocity actuators lag the twist by a few ms of physics


class TestSimCamera(InSimWorld, CameraConformance):
    driver = "sim.camera"
    config = {"camera": "front", "width": 48, "height": 32, "depth": True}
    bad_config = {"camera": "no_such_camera"}


class TestSimWrench(InSimWorld, WrenchConformance):
    """The so100's wrist, holding still at home: tared, only the physics' residue remains."""

    driver = "sim.wrench"
    bad_config = {"arm": "no_such_arm"}
    tare_tol_n = 0.05
    tare_tol_nm = 0.01


class TestSimWorld(SensorConformance):
    driver = "sim.world"
    config = {"scene": "so100", "world": "kit-sensor-world"}
