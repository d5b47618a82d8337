"""What every servo-driving node of this plugin does the same way: open its calibrated servos on the
arm's bus, read them once per tick (servo error bits stop the node, naming the servo), switch their
torque, and always release the port. The kinds' contracts (`rio.interfaces`) do the rest."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from rio.config import Config

from .connection import ArmConnection


class ServoConfig(Config):
    """Station fields every SO-arm servo node takes (mixed into each driver's Config)."""

    port: str = Field(description='serial port of the arm\'s bus (e.g. /dev/ttyACM0), or "virtual" for an '
                                  'emulated arm, or "sim:ARM@WORLD" for servos backed by rio-sim')
    calibration: str = Field("default", description="calibration name (in $XDG_CONFIG_HOME/rio/calibration/"
                                                    "<model>-<device>/) or a .json path")
    model: Literal["so100", "so101"] = Field("so100", description="which arm (selects the calibration folder)")
    baudrate: int = 1_000_000
    retries: int = Field(2, ge=0, le=10, description="retries of a failed exchange before it is an error")


class ServoDriver:
    """Mixed into a node whose config is a `ServoConfig` and whose `device` names its calibration device."""

    config: Any
    device: str
    group: Any = None
    conn: ArmConnection | None = None
    enabled: bool = False

    def open_group(self, joints: list[str], virtual_motion: str = "none") -> None:
        c = self.config
        self.conn = ArmConnection(c.port, model=c.model, device=self.device, calibration=c.calibration,
                                  baudrate=c.baudrate, retries=c.retries, virtual_motion=virtual_motion)
        self.group = self.conn.open(joints)

    def read_group(self) -> dict[str, Any]:
        """One SYNC READ; servo error bits raise `ServoFault` (freezing the servos first when enabled)."""
        s = self.group.read()
        self.group.check_faults(s, hold=self.enabled)
        return s

    def hardware_limits(self) -> Any:
        return self.group.limits_rad()

    def set_enabled(self, enabled: bool) -> None:
        """Torque on holds the present position (goal = present first, so nothing jumps)."""
        self.group.set_torque(bool(enabled))

    def close(self) -> None:
        if self.conn is not None:
            self.conn.close()
