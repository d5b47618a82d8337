"""A Universal Robots controller emulator at the protocol boundary: ur-rtde's `RTDEReceiveInterface`
and `DashboardClient` talk to it over the controller's real protocols (RTDE on 30004, the Dashboard
Server on 29999), and it moves a model of the arm (or a rio-sim arm). The control path is the one
thing faked: see `servo.py`.

    from rio_ur.emulator import UREmulator
    with UREmulator("ur5e", host="127.0.0.7") as emu:
        ...  # RTDEReceiveInterface("127.0.0.7"), DashboardClient("127.0.0.7") work as against a UR5e

`rio ur emulator --model ur5e` runs one until Ctrl-C.
"""

from __future__ import annotations

from typing import Any

from ..loopback import DASHBOARD_PORT, RTDE_PORT, SERVO_PORT
from ..models import get_arm
from .dashboard import DashboardServer
from .robot import URRobot
from .rtde import RtdeServer
from .servo import ServoServer


class UREmulator:
    """The controller's servers on `host` around one `URRobot`. `backend`: "model" or "sim[:ARM[@WORLD]]"
    (the joints of a running rio-sim world); `urcap`: also serve a Robotiq URCap socket (63352) whose
    fingers are the sim's (needs rio-robotiq)."""

    def __init__(self, model: str = "ur5e", host: str = "127.0.0.2", backend: str = "model",
                 urcap: bool = False):
        self.arm = get_arm(model)
        self.host, self.backend = host, backend
        self.world_arm: Any = None
        joints = None
        if backend != "model":
            from .sim import attach

            self.world_arm, joints = attach(backend)
        self.robot = URRobot(self.arm, joints)
        self.rtde = RtdeServer(self.robot, host, RTDE_PORT)
        self.dashboard = DashboardServer(self.robot, host, DASHBOARD_PORT)
        self.servo = ServoServer(self.robot, host, SERVO_PORT)
        self.servo.drop_all = self.drop_clients
        self.urcap: Any = None
        if urcap:
            from .sim import urcap_server

            self.urcap = urcap_server(host, self.world_arm)

    def start(self) -> UREmulator:
        self.robot.start()
        for s in self.servers:
            s.start()
        return self

    @property
    def servers(self) -> list[Any]:
        return [s for s in (self.rtde, self.dashboard, self.servo, self.urcap) if s is not None]

    def stop(self) -> None:
        for s in self.servers:
            s.stop()
        self.robot.stop()

    def drop_clients(self) -> int:
        """Cut every connection (a pulled cable, a rebooted controller); the servers keep listening."""
        return sum(s.drop_clients() for s in self.servers)

    @property
    def driver_fields(self) -> dict[str, Any]:
        """Station fields that point a `ur.*` driver at this emulator."""
        return {"ip": self.host, "control": "emulator", "connect_timeout_s": 5.0}

    def __enter__(self) -> UREmulator:
        return self.start()

    def __exit__(self, *exc: Any) -> None:
        self.stop()


__all__ = ["UREmulator", "URRobot"]
