"""`ufactory.emulator`: an xArm controller emulator as a station component, so a station file alone
gives the real SDK something to talk to (like `sim.world` gives sim drivers a world).

It listens on `ip` at the controller's real ports; the arm and gripper components of the station
connect to that same `ip` and retry until it is up. Its sample is the emulator's ground truth (joints
and error code), recorded under `meta.sensors.emulator.*` where a station records.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio.runtime.node import Node, NodeConfig

from .models import ARMS, get_arm


class EmulatorNode(Node):
    class Config(NodeConfig):
        model: Literal["xarm5", "xarm6", "xarm7", "xarm850", "lite6"] = Field(
            "xarm7", description=f"which controller to emulate: {', '.join(ARMS)}")
        ip: str = Field("127.0.0.2", description="loopback address to listen on (the controller's ports 502, "
                                                 "30001-30003 on it; a distinct 127.0.0.N per emulator)")
        backend: str = Field("model", description='"model" (a first-order arm model) or "sim:ARM@WORLD" (the '
                                                  'joints of a running rio-sim world, e.g. "sim")')
        gripper: Literal["xarm", "bio", "lite6", "robotiq", "none"] = Field(
            "xarm", description="device on the tool connector")
        rate_hz: float = Field(10.0, gt=0, description="how often the ground truth is published")

    def setup(self) -> None:
        self.emulator: Any = None
        self.example_data = {"joint_pos": np.zeros(get_arm(self.config.model).axis), "error_code": 0}

    def open(self) -> None:
        from .emulator import XArmEmulator

        c = self.config
        emulator = XArmEmulator(model=c.model, host=c.ip, backend=c.backend,
                                gripper=None if c.gripper == "none" else c.gripper)
        if emulator.machine.kin is None:  # a station's arm streams poses: the box would refuse every one
            emulator.stop()
            raise ImportError(f"node '{self.name}': the xArm emulator's Cartesian commands and poses need RIO's "
                              "kinematics of the arm (mujoco, mink): pip install 'rio-ufactory[ik]'")
        self.emulator = emulator
        self.emulator.start()

    def read_state(self) -> dict[str, Any]:
        return {"joint_pos": np.asarray(self.emulator.joint_pos, dtype=np.float64),
                "error_code": int(self.emulator.error_code)}

    def close(self) -> None:
        if self.emulator is not None:
            self.emulator.stop()
            self.emulator = None
