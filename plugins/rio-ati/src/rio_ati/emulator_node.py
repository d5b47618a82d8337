"""`ati.emulator`: an emulated Net F/T box as a station component, so a station file alone gives the real
driver a box to talk to (as `ufactory.emulator` does for the xArm SDK). It listens on `ip` at the RDT
port and serves its configuration page at `http_port`; the `ati.netft` component names the same
addresses. Its sample is the load it applies (N, N m), recorded as `meta.sensors.<name>.load`.

With `backend = "sim:ARM@WORLD"` (`"sim"`: the arm `arm` of the world `sim`) the load is that sim arm's
wrist force/torque sensor (`rio_ati.sim_source`): the real driver then reads physics through the box's
protocol."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio.runtime.node import Node, NodeConfig, remote

from .rdt import PORT


class EmulatorNode(Node):
    class Config(NodeConfig):
        ip: str = Field("127.0.0.12", description="loopback address to listen on (a distinct 127.0.0.N per box)")
        rdt_port: int = Field(PORT, ge=1, le=65535, description="RDT port (UDP)")
        http_port: int = Field(8080, ge=1, le=65535, description="port of the configuration page (a real box: 80)")
        load: list[float] = Field(default_factory=lambda: [0.0, 0.0, -4.9, 0.0, 0.05, 0.0], min_length=6,
                                  max_length=6, description="the wrench applied to the cell (N, N m)")
        noise: float = Field(0.02, ge=0, description="standard deviation of each reading's noise (N, N m)")
        box_rate_hz: float = Field(1000.0, gt=0, le=7000, description="the box's RDT rate")
        backend: str = Field("load", description='"load" (the constant `load`) or "sim:ARM@WORLD" (a running rio-sim '
                                                 'world\'s wrist force/torque sensor, e.g. "sim")')
        rate_hz: float = Field(10.0, gt=0, description="how often the applied load is published")

    def setup(self) -> None:
        self.box: Any = None
        self.source: Any = None
        self.example_data = {"load": np.zeros(6)}
        self.sim_target = None
        if self.config.backend != "load":
            from rio_sim.world_arm import parse_sim_target  # no MuJoCo: the name's grammar only

            self.sim_target = parse_sim_target(self.config.backend)
            if self.sim_target is None:
                raise ValueError(f"backend '{self.config.backend}' is neither \"load\" nor \"sim:ARM@WORLD\"")

    def open(self) -> None:
        from .emulator import NetFTBox

        c = self.config
        if self.sim_target is not None:
            from .sim_source import WristSource

            arm, world = self.sim_target
            self.source = WristSource(world, arm)
        self.box = NetFTBox(c.load, host=c.ip, rdt_port=c.rdt_port, http_port=c.http_port, rate_hz=c.box_rate_hz,
                            noise=c.noise, source=self.source).start()

    def read_state(self) -> dict[str, Any]:
        return {"load": self.box.last_load.copy()}

    @remote
    def apply(self, load: list[float]) -> None:
        """Apply another wrench to the emulated cell (N, N m)."""
        self.box.load = np.asarray(load, dtype=np.float64).reshape(6)

    def close(self) -> None:
        if self.box is not None:
            self.box.stop()
            self.box = None
        if self.source is not None:
            self.source.close()
            self.source = None
