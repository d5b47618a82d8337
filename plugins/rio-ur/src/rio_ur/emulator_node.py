"""`ur.emulator`: a UR controller emulator as a station component, so a station file alone gives the
real ur-rtde something to talk to. It runs the emulator in a process of its own (ur-rtde's blocking
calls hold the GIL); its sample is the emulator's ground truth (joints, safety mode)."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio.runtime.node import Node, NodeConfig


class EmulatorNode(Node):
    class Config(NodeConfig):
        model: str = Field("ur5e", description="which arm to emulate")
        ip: str = Field("127.0.0.2", description="loopback address to listen on (29999, 30004, 30020)")
        backend: str = Field("model", description='"model" or "sim[:ARM@WORLD]" (a running rio-sim world)')
        urcap: bool = Field(False, description="also serve a Robotiq URCap socket (63352)")
        rate_hz: float = Field(10.0, gt=0, description="how often the ground truth is published")
        connect_timeout_s: float = Field(120.0, gt=0, description="how long to wait for the emulator to answer "
                                         "(backend sim: it first waits for the world to compile its scene)")

    def setup(self) -> None:
        self.emulator: Any = None
        self.example_data = {"joint_pos": np.zeros(6), "safety_mode": 1}

    def open(self) -> None:
        from .emulator.process import EmulatorProcess

        c = self.config
        self.emulator = EmulatorProcess(c.model, c.ip, c.backend, c.urcap).wait_ready(c.connect_timeout_s)

    def read_state(self) -> dict[str, Any]:
        s = self.emulator.state()
        return {"joint_pos": np.asarray(s["q"], dtype=np.float64), "safety_mode": int(s["safety_mode"])}

    def close(self) -> None:
        if self.emulator is not None:
            self.emulator.stop()
            self.emulator = None
