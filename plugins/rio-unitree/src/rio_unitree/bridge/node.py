"""`unitree.bridge`: the bridge as a station component, so a station file alone gives the G1 driver a
robot to talk to (as `sim.world` does for sim drivers). The driver component of the same station
retries for its `connect_timeout_s` while the bridge compiles its model and starts.

Its sample is the simulation's ground truth and the bridge's counters, recorded under
`meta.sensors.bridge.*` where a station records.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field
from rio.node import Node, NodeConfig


class BridgeNode(Node):
    class Config(NodeConfig):
        interface: str = Field("lo", description="network interface the bridge publishes on")
        domain_id: int = Field(0, ge=0, le=232, description="DDS domain (use the driver's)")
        model: str | None = Field(None, description='MJCF path, "fallback" (the plugin\'s own G1-like model), "hands" '
                                                    "(rio-sim's G1 with Dex3-1 hands: also rt/dex3/*), or unset: "
                                                    "rio-sim's G1 when installed, else the fallback")
        mounted: bool = Field(True, description="pelvis welded to the world (a G1 on its gantry)")
        state_rate_hz: float = Field(500.0, gt=0, description="rt/lowstate rate (the robot's is 500 Hz)")
        rate_hz: float = Field(10.0, gt=0, description="how often the ground truth is published")

    def setup(self) -> None:
        self.bridge: Any = None
        self.example_data = {"joint_pos": np.zeros(29), "bad_crc": 0, "lowcmd": 0, "arm_sdk": 0}

    def open(self) -> None:
        from .sim import Bridge

        c = self.config
        self.bridge = Bridge(domain_id=c.domain_id, interface=c.interface, model=c.model, mounted=c.mounted,
                             state_rate_hz=c.state_rate_hz).start()

    def read_state(self) -> dict[str, Any]:
        b = self.bridge
        q = np.full(29, np.nan)
        q[b.sim.slots] = b.joint_pos()
        return {"joint_pos": q, "bad_crc": b.counts.bad_crc, "lowcmd": b.counts.lowcmd, "arm_sdk": b.counts.arm_sdk}

    def close(self) -> None:
        if self.bridge is not None:
            self.bridge.stop()
            self.bridge = None
