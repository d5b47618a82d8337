"""`unitree.bridge`: the bridge as a station component, so a station file alone gives the G1 driver a
robot to talk to (as `sim.world` does for sim drivers). The driver component of the same station
retries for its `connect_timeout_s` while the bridge compiles its model and starts.

Its sample is the simulation's ground truth (joints, the pelvis' pose, the share of the robot's weight
the gantry carries, the simulated time) and the bridge's counters, recorded under `meta.sensors.bridge.*`
where a station records. `release_gantry()` (a remote call) lowers the gantry of a free G1.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio.runtime.node import Node, NodeConfig, remote


class BridgeNode(Node):
    class Config(NodeConfig):
        interface: str = Field("lo", description="network interface the bridge publishes on")
        domain_id: int = Field(0, ge=0, le=232, description="DDS domain (use the driver's)")
        model: str | None = Field(None, description='MJCF path, "fallback" (the plugin\'s own G1-like model), "hands" '
                                                    "(rio-sim's G1 with Dex3-1 hands: also rt/dex3/*), or unset: "
                                                    "rio-sim's G1 when installed, else the fallback")
        mounted: bool = Field(True, description="pelvis welded to the world (false: free on a floor)")
        hands: Literal["inspire"] | None = Field(None, description='"inspire": also the G1\'s two Inspire hands, '
                                                                  "emulated (rt/inspire/*; no physics)")
        gantry: bool = Field(False, description="free G1 only: a gantry holds the pelvis up from the start until "
                                                "released, then lowers it onto its feet (`rio_unitree.bridge.gantry`)")
        release_after_s: float | None = Field(
            None, ge=0, description="lower the gantry this long after the legs are first commanded stiff on "
                                    "rt/lowcmd (None: only on release_gantry())")
        lower_s: float = Field(2.0, gt=0, description="seconds the gantry takes to hand the weight to the feet")
        start_pose: dict[str, float] | None = Field(None, description="joint -> angle (rad) the robot starts in and "
                                                                      "its stand-in holds (default: the G1's home)")
        state_rate_hz: float = Field(500.0, gt=0, description="rt/lowstate rate (the robot's is 500 Hz)")
        rate_hz: float = Field(10.0, gt=0, description="how often the ground truth is published")

    def setup(self) -> None:
        self.bridge: Any = None
        self.example_data = {"joint_pos": np.zeros(29), "base_pos": np.zeros(3), "base_quat": np.zeros(4),
                             "gantry_load": 0.0, "sim_time": 0.0, "bad_crc": 0, "lowcmd": 0, "arm_sdk": 0}

    def open(self) -> None:
        from .sim import Bridge

        c = self.config
        self.bridge = Bridge(domain_id=c.domain_id, interface=c.interface, model=c.model, mounted=c.mounted,
                             state_rate_hz=c.state_rate_hz, start_pose=c.start_pose, gantry=c.gantry,
                             release_after_s=c.release_after_s, lower_s=c.lower_s,
                             hands=c.hands).start()

    def read_state(self) -> dict[str, Any]:
        b = self.bridge
        q = np.full(29, np.nan)
        q[b.sim.slots] = b.joint_pos()
        pos, quat = b.base_pose()
        with b.lock:
            t = float(b.sim.data.time)
            load = b.gantry.load(t) if b.gantry is not None else 0.0
        return {"joint_pos": q, "base_pos": pos, "base_quat": quat, "gantry_load": load, "sim_time": t,
                "bad_crc": b.counts.bad_crc, "lowcmd": b.counts.lowcmd, "arm_sdk": b.counts.arm_sdk}

    @remote
    def release_gantry(self) -> None:
        """Lower the gantry now: the free G1's feet take its weight over `lower_s`."""
        self.bridge.release_gantry()

    def close(self) -> None:
        if self.bridge is not None:
            self.bridge.stop()
            self.bridge = None
