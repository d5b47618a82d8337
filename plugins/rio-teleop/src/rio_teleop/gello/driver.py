"""The GELLO leader arm: a teleop node publishing the follower's joint angles as a person moves it.

Each tick it Sync-Reads the servos' present positions and velocities (dynamixel-sdk, Protocol 2.0),
maps them through the leader's calibration (`q = sign * (raw - offset)`) and publishes `joint_pos` /
`joint_vel` in the follower's convention and the trigger as `gripper` (0 squeezed/closed .. 1
released/open), which `rio teleop` scales to the follower gripper's range. It also carries the keys
every `TeleopNode` has (`twist` zero, `buttons`). Servos are torque-off (moved by hand), except the
trigger when `trigger_current_ma` > 0: current-based position mode holding the released position,
so the trigger springs back like GELLO's newer builds.

`port = "emulator"` starts a `GelloEmulator` inside the node (held in the layout's known pose, or
waving with `emulator_motion = "wave"`), read through the same SDK path.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio.interfaces import ServoBus, TeleopNode
from rio.runtime.node import client_side, remote

from . import control_table as T
from .bus import DynamixelBus
from .calibration import GelloCalibration, load_calibration
from .layouts import LAYOUTS, get_layout

EMULATOR = "emulator"
_ZERO_TWIST = np.zeros(6)


class GelloLeader(TeleopNode):
    client_state = ("joint_list",)

    class Config(ServoBus, TeleopNode.Config):
        # the XL330s' factory baud rate (1000000 reads 8 servos in ~2 ms); the port is the U2D2's
        defaults = {"baudrate": 57600, "rate_hz": Field(100.0, le=1000)}
        renamed = {"virtual_motion": "emulator_motion"}
        layout: Literal[tuple(LAYOUTS)] = Field(description="which GELLO design: " + ", ".join(LAYOUTS))  # type: ignore[valid-type]
        calibration: str = Field("default", description="calibration name (in $XDG_CONFIG_HOME/rio/calibration/"
                                                        "gello-<layout>/) or a .json path")
        gripper: bool = Field(True, description="read the trigger and publish it as `gripper`")
        trigger_current_ma: float = Field(0.0, ge=0, le=1750, description="> 0: the trigger servo holds its "
                                          "released position with this current (a spring); 0: torque off")
        emulator_motion: Literal["none", "wave"] = Field("none", description='with port = "emulator": a scripted '
                                                                           'hand moving the leader ("wave")')

    leader_arm = True  # `rio teleop` mirrors it joint by joint

    def setup(self) -> None:
        super().setup()
        self.layout = get_layout(self.config.layout)
        self.joint_list = list(self.layout.joint_names())
        n = self.layout.dof
        self.example_data = {**self.example_data, "joint_pos": np.zeros(n), "joint_vel": np.zeros(n)}
        self._no_buttons = np.zeros(self.config.buttons, bool)
        self.emulator = None
        self.bus: DynamixelBus | None = None

    def _calibration(self) -> GelloCalibration:
        if self.emulator is not None and self.config.calibration == "default":
            return self.emulator.mounting
        return load_calibration(self.config.calibration, self.layout, port=self.config.port)

    def open(self) -> None:
        c, lay = self.config, self.layout
        path = c.port
        if c.port == EMULATOR:
            from .emulator.gello import GelloEmulator, attach_motion

            self.emulator = GelloEmulator(lay, baudrate=c.baudrate)
            attach_motion(self.emulator, c.emulator_motion)
            path = self.emulator.port
        self.ids = lay.joint_ids + ((lay.gripper_id,) if c.gripper and lay.gripper_id is not None else ())
        self.bus = DynamixelBus(path, baudrate=c.baudrate, retries=c.retries, names=lay.servo_names(),
                                label=c.port).open()
        self.models = self.bus.check_present(self.ids)
        self.cal = self._calibration()
        for sid in lay.joint_ids:
            self.bus.write(sid, T.TORQUE_ENABLE, 0)
        if len(self.ids) > lay.dof:
            self._trigger(self.ids[-1], c.trigger_current_ma)

    def _trigger(self, sid: int, current_ma: float) -> None:
        bus = self.bus
        bus.write(sid, T.TORQUE_ENABLE, 0)
        if current_ma > 0:
            bus.write(sid, T.OPERATING_MODE, T.CURRENT_POSITION)
            bus.write(sid, T.GOAL_CURRENT, int(round(current_ma)))
            bus.write(sid, T.GOAL_POSITION, int(round(self.cal.gripper_open / T.RAD_PER_STEP)))
            bus.write(sid, T.TORQUE_ENABLE, 1)

    def read_state(self) -> dict[str, Any]:
        pos, vel = self.bus.read_state(self.ids)
        n = self.layout.dof
        grip = self.cal.gripper(float(pos[n])) if len(self.ids) > n else 1.0
        return {"twist": _ZERO_TWIST, "gripper": grip, "buttons": self._no_buttons,
                "joint_pos": self.cal.joints(pos[:n]), "joint_vel": np.asarray(self.cal.signs, float) * vel[:n]}

    def close(self) -> None:
        if self.bus is not None:
            try:
                if len(self.ids) > self.layout.dof and self.config.trigger_current_ma > 0:
                    self.bus.write(self.ids[-1], T.TORQUE_ENABLE, 0)
            except Exception:
                pass
            self.bus.close()
            self.bus = None
        if self.emulator is not None:
            self.emulator.close()
            self.emulator = None

    @client_side
    def joint_names(self) -> list[str]:
        return list(self.joint_list)

    @client_side
    def num_joints(self) -> int:
        return len(self.joint_list)

    @remote
    def known_pose(self) -> list[float]:
        """The layout's calibration pose (follower joint angles, rad)."""
        return list(self.layout.known_pose)
