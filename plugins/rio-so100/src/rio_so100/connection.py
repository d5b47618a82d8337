"""Opening an SO-arm's bus for a driver: the real port or a private emulated bus, presence and model
checks, and the calibration put into the servos. Shared by the follower, gripper and leader drivers
so each of them is only its control logic.

`port = "emulator"` starts a `FeetechBusEmulator` inside the driver's process and opens its pty through the
same SDK code path as a real port; without a calibration file it uses `default_calibration()`.
`port = "sim"` (`"sim:ARM@WORLD"`) does the same with servos that are joints of a running rio-sim
world (`rio_so100.emulator.sim`), calibrated from the sim model.
"""

from __future__ import annotations

from .calibration import apply_calibration, load_calibration
from .errors import BusError
from .feetech import control_table as T
from .feetech.bus import FeetechBus
from .servo_group import ServoGroup

EMULATOR = "emulator"




def is_emulator(port: str) -> bool:
    return port == EMULATOR


class ArmConnection:
    def __init__(self, port: str, *, model: str, device: str, calibration: str, baudrate: int = 1_000_000,
                 retries: int = 2, emulator_motion: str = "none"):
        self.port, self.model, self.device, self.calibration = port, model, device, calibration
        self.baudrate, self.retries, self.emulator_motion = baudrate, retries, emulator_motion
        self.emulator = None
        self.bus: FeetechBus | None = None

    def open(self, joint_names: list[str]) -> ServoGroup:
        from .emulator.sim import parse_sim_port

        path, cal = self.port, None
        if is_emulator(self.port):
            from .emulator import FeetechBusEmulator
            from .emulator.hand import attach_motion

            self.emulator = FeetechBusEmulator()
            attach_motion(self.emulator, self.emulator_motion)
            path = self.emulator.port
        elif parse_sim_port(self.port):
            from .emulator.sim import open_sim_bus

            self.emulator, cal = open_sim_bus(self.port)
            path = self.emulator.port
        if cal is None:
            cal = load_calibration(self.calibration, self.model, self.device, emulated=self.emulator is not None)
        joints = {name: cal.joint(name) for name in joint_names}
        names = {j.id: n for n, j in joints.items()}
        # (an emulated bus gets the slack its thread needs on a loaded machine: rio.machine.servo_port)
        self.bus = FeetechBus(path, baudrate=self.baudrate, retries=self.retries, names=names).open()
        check_present(self.bus, names, self.port)
        apply_calibration(self.bus, joints)
        return ServoGroup(self.bus, joints)

    def close(self) -> None:
        if self.bus is not None:
            self.bus.close()
            self.bus = None
        if self.emulator is not None:
            self.emulator.close()
            self.emulator = None


def check_present(bus: FeetechBus, ids, port: str | None = None) -> None:
    """Every id answers a ping and is an STS3215, or one BusError naming each one that is not."""
    port = port or bus.port
    found = bus.find(ids)
    missing = [sid for sid, model in found.items() if model is None]
    if missing:  # one more look before giving up: a scan does not retry
        again = bus.find(missing)
        missing = [sid for sid in missing if again[sid] is None]
        found.update(again)
    if missing:
        who = ", ".join(bus.servo_name(s) for s in missing)
        raise BusError(f"{port}: {who} did not answer a ping (servos that did: "
                       f"{sorted(s for s, m in found.items() if m is not None) or 'none'}); check power, "
                       "cables and ids, and that this is the right port")
    wrong = {sid: m for sid, m in found.items() if m != T.STS3215_MODEL}
    if wrong:
        raise BusError(f"{port}: " + ", ".join(f"{bus.servo_name(s)} is model {m}" for s, m in wrong.items())
                       + f", not an STS3215 ({T.STS3215_MODEL})")
