"""Robot state shown back on a teleop device (the WebXR page's status panel, a headset's overlay).

A device that offers `feedback(state)` in its API gets each arm's measured tool position and
gripper opening a few times a second: enough for an operator glancing at a panel, and a remote call
cheap enough to make from the control loop's thread at that rate. A device that stops answering
loses its feedback, not the run: the panel is a convenience, the robot is driven by the samples.
"""

from __future__ import annotations

from typing import Any

from rio.errors import RioError


class DeviceFeedback:
    def __init__(self, devices: dict[str, Any], rate_hz: float = 10.0, log: Any = None):
        self.targets = {r: d for r, d in devices.items() if "feedback" in dir(d)}
        self.period, self.log = 1.0 / rate_hz, log
        self.t_next = 0.0

    def __call__(self, t: float, arms: list[Any]) -> None:
        if not self.targets or t < self.t_next:
            return
        self.t_next = t + self.period
        state: dict[str, Any] = {}
        for b in arms:
            state[f"{b.role}_xyz"] = [float(v) for v in b.client.get_state()["eef_pose"][:3]]
            if b.gripper is not None:
                state[f"{b.role}_gripper_m"] = float(b.gripper.get_state()["width"])
        for role, dev in list(self.targets.items()):
            try:
                dev.feedback(state)
            except (RioError, TimeoutError, OSError) as e:
                del self.targets[role]
                if self.log is not None:
                    self.log(f"teleop device '{role}' stopped taking feedback ({e}); the run goes on")
