"""What every servo-driving node of this plugin does the same way, as a part each holds (`self.servos`):
open its calibrated servos on the arm's bus, read them once per tick (servo error bits stop the node,
naming the servo), and always release the port. The kinds' contracts (`rio.interfaces`) do the rest."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from rio.interfaces import ServoBus

from .connection import ArmConnection
from .servo_group import ServoGroup


class ServoConfig(ServoBus):
    """Station fields every SO-arm servo node takes (mixed into each driver's Config): the bus (`port`:
    also "sim:ARM@WORLD" for servos backed by rio-sim), the calibration and the model."""

    calibration: str = Field("default", description="calibration name (in $XDG_CONFIG_HOME/rio/calibration/"
                                                    "<model>-<device>/) or a .json path")
    model: Literal["so100", "so101"] = Field("so100", description="which arm (selects the calibration folder)")


class Servos:
    """A node's calibrated servos (`group`, once open) on the bus its config names; `device` names the
    calibration ("follower", "leader")."""

    def __init__(self, config: Any, device: str):
        self.config, self.device = config, device
        self.conn: ArmConnection | None = None
        self.group: Any = None

    def open(self, joints: list[str], emulator_motion: str = "none") -> ServoGroup:
        c = self.config
        self.conn = ArmConnection(c.port, model=c.model, device=self.device, calibration=c.calibration,
                                  baudrate=c.baudrate, retries=c.retries, emulator_motion=emulator_motion)
        self.group = self.conn.open(joints)
        return self.group

    def read(self, hold: bool) -> dict[str, Any]:
        """One SYNC READ; servo error bits raise `ServoFault` (freezing the servos first when `hold`: the node
        drives them)."""
        s = self.group.read()
        self.group.check_faults(s, hold=hold)
        return s

    def close(self) -> None:
        if self.conn is not None:
            self.conn.close()
