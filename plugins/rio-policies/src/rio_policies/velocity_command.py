"""A teleop device's twist as a locomotion policy's velocity command [vx m/s, vy m/s, wz rad/s].

The device is one of the station's teleop components (keyboard, spacemouse, `teleop.scripted`, ...),
served beside the robot during `rio deploy`; the policy node reads its newest sample in place from its ring
(`ObsLayout.inputs`, a `rio.runtime.ring_ref` reference), as it reads camera frames, so nothing of the control
loop changes for it. Its linear x, linear y and angular z (the twist's 0, 1 and 5: base frame, x forward, z
up) are multiplied by `gain`, zeroed within `deadband` (a spacemouse at rest is never exactly still) and
clipped to +-`command_max`. A device that has published nothing yet, or nothing for `timeout_s` (it stopped),
commands standing still: a walking robot must not keep walking on a command nobody is giving any more.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rio import clock

#: The twist's components that make the command: linear x, linear y, angular z.
TWIST_AXES = (0, 1, 5)


def twist_to_command(twist: Any, gain: Any, deadband: Any, command_max: Any) -> np.ndarray:
    """[vx, vy, wz] from a 6-vector twist (see the module docstring)."""
    v = np.asarray(twist, dtype=np.float64)[list(TWIST_AXES)] * np.asarray(gain, dtype=np.float64)
    v[np.abs(v) < np.asarray(deadband, dtype=np.float64)] = 0.0
    lim = np.asarray(command_max, dtype=np.float64)
    return np.clip(v, -lim, lim)


class DeviceCommand:
    """The velocity command from the teleop device at station role `role`, read from `layout.inputs`."""

    def __init__(self, layout: Any, role: str, gain: Any, deadband: Any, command_max: Any, timeout_s: float):
        from rio.runtime.ring_ref import SharedRing

        refs = getattr(layout, "inputs", None) or {}
        if role not in refs:
            raise ValueError(f"command_from = '{role}': no teleop device '{role}' whose samples the policy can read "
                             f"(readable: {sorted(refs) or 'none'}); add [components.{role}] with a teleop driver "
                             "to the station, and run it over a middleware that shares rings (shm, thread)")
        self.ring = SharedRing(refs[role])
        if "twist" not in refs[role].get("sample", {}):
            self.ring.close()
            raise ValueError(f"command_from = '{role}': that device publishes no twist")
        self.role, self.gain, self.deadband, self.command_max = role, gain, deadband, command_max
        self.timeout_s = float(timeout_s)

    def __call__(self) -> np.ndarray:
        buf = self.ring.ring_buffer
        if buf.count == 0:
            return np.zeros(3)
        sample = buf.get()
        if clock.now() - float(sample["timestamp"]) > self.timeout_s:
            return np.zeros(3)
        return twist_to_command(sample["twist"], self.gain, self.deadband, self.command_max)

    def close(self) -> None:
        self.ring.close()
