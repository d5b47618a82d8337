"""The load of an emulated Net F/T from a running rio-sim world: the wrist force/torque sensor of one of its
arms (`rio_sim.wrist_ft`), so the real `ati.netft` driver reads physics (a tool touching the table, an object
picked up) through the box's own protocol. Needs rio-sim (`pip install 'rio-ati[sim]'`).

    source = wrist_source("sim", "arm")        # waits for the world to come up
    box = NetFTBox(source=source)              # every record: the sensor's force and torque now
    ...
    source.close()
"""

from __future__ import annotations

import numpy as np


class WristSource:
    """Callable: the wrist force (N) and torque (N m) of `arm` in `world` now, 6 values in the `<arm>/ft` site's
    frame. Call it from one thread (it reuses a buffer)."""

    def __init__(self, world: str = "sim", arm: str = "arm", timeout: float = 60.0):
        from rio_sim.attached import WorldAttachment
        from rio_sim.wrist_ft import wrist_ft_indices

        self.sim = WorldAttachment(world)
        self.sim.attach()
        try:
            self.idx = wrist_ft_indices(self.sim.model, arm)
        except KeyError:
            self.sim.detach()
            raise

    def __call__(self) -> np.ndarray:
        return self.sim.state()["sensordata"][self.idx].copy()

    def close(self) -> None:
        self.sim.detach()


def wrist_source(world: str = "sim", arm: str = "arm") -> WristSource:
    return WristSource(world, arm)
