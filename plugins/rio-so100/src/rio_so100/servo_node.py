"""What every servo-driving node of this plugin does the same way: start the commander on the
calibrated limits, run one bus cycle per tick, switch torque, and always release the port."""

from __future__ import annotations

from typing import Any

from rio import time as rtime

from .safety import JointCommander


class ServoNodeMixin:
    """Mixed into a driver that has `conn`, `group`, `max_step`, `watchdog_s`, `_torque`,
    `disable_torque_on_close` (set by its `__init__` / `open`)."""

    def _start(self) -> None:
        lower, upper = self.group.limits_rad()
        self.commander = JointCommander(lower, upper, self.max_step, self.watchdog_s)
        self.torque(True)

    def _cycle(self) -> dict[str, Any]:
        """One tick: SYNC READ, stop on servo error bits, then SYNC WRITE this cycle's goal."""
        s = self.group.read()
        self.group.check_faults(s, hold=self._torque)
        if self._torque:
            self.group.write_rad(self.commander.step(rtime.now()))
        return s

    def torque(self, enabled: bool = True) -> bool:
        """Enable (hold the present pose) or disable (limp) the servos' torque."""
        self.group.set_torque(bool(enabled))
        self._torque = bool(enabled)
        if enabled:
            self.commander.reset(self.group.read()["joint_pos"], rtime.now())
        return self._torque

    def close(self) -> None:
        try:
            if self.group is not None and self.disable_torque_on_close and self._torque:
                self.group.set_torque(False)
        except Exception:
            pass  # closing must release the port whatever state the bus is in
        finally:
            self.conn.close()
