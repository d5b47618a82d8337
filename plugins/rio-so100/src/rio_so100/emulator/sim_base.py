"""An emulated bus whose wheel servos turn with the mobile base of a running rio-sim world: LeKiwi's wheel
driver (`lekiwi.base`, `port = "sim"`) against physics, as `rio_so100.emulator.sim` does for the arm.

`port = "sim"` (or `"sim:BASE"`, `"sim:BASE@WORLD"`; BASE is the scene's base prefix, default `base`) gives
the driver a private `FeetechBusEmulator` with servos 7-9 whose registers are the STS3215's (wheel mode set
through the EEPROM, torque, goal speed in sign-magnitude steps/s) and whose motion is the world's base,
through rio-sim's `WorldBase`. The world's base is a planar body driven by its body twist, not wheel contacts,
so the wheels are LeKiwi's geometry (`rio_so100.lekiwi.geometry`) on both sides of it:

- a goal speed written to any wheel: the three wheels' goal speeds (zero for a wheel with torque off or not
  in wheel mode), through the omni-wheel forward kinematics, are the body twist sent to the world's base;
- a read: each wheel turns at its share of the base's *measured* body twist (the inverse kinematics), its
  encoder integrated over simulated time, so the driver's odometry sees what the base did, slip-free.

The driver above is unchanged: scservo_sdk packets over a pty, wheel mode, SYNC READ and SYNC WRITE.
"""

from __future__ import annotations

import numpy as np

from rio import clock
from rio.control.omni import OmniKinematics

from ..feetech import control_table as T
from ..lekiwi import geometry as G
from .bus import FeetechBusEmulator
from .servo import STS3215Emulator

#: A twist reaches the world as a target this far ahead (s): the servo's "as fast as you can".
TWIST_LEAD_S = 0.02
_DRIVES = (T.GOAL_VELOCITY[0], T.TORQUE_ENABLE[0], T.OPERATING_MODE[0])


def parse_sim_base_port(port: str) -> tuple[str, str] | None:
    """'sim' -> ('base', 'sim'); 'sim:b2@w' -> ('b2', 'w'); 'sim:@w' -> ('base', 'w'); else None."""
    if port != "sim" and not port.startswith("sim:"):
        return None
    base, _, world = port[4:].partition("@")
    return base or "base", world or "sim"


class SimWheels:
    """The three wheels of LeKiwi's geometry on a world's base (`rio_sim.world_base.WorldBase`)."""

    def __init__(self, base, ids: list[int]):
        self.base, self.ids = base, list(ids)
        self.kinematics = OmniKinematics.from_degrees(G.PUSH_ANGLES_DEG, G.WHEEL_RADIUS, G.BASE_RADIUS)
        self.servos: dict[int, SimWheelServo] = {}

    def measured(self, servo_id: int) -> tuple[float, float]:
        """(wheel `servo_id`'s speed, steps/s, from the base's measured twist; the simulated time)."""
        twist, t_sim = self.base.body_twist()
        speeds = self.kinematics.to_wheels(twist) * G.STEPS_PER_RAD
        return float(speeds[self.ids.index(servo_id)]), t_sim

    def drive(self) -> None:
        """Send the world's base the body twist of the wheels' goal speeds."""
        goals = np.array([self.servos[sid].goal_speed() for sid in self.ids]) / G.STEPS_PER_RAD
        self.base.command_twist(self.kinematics.to_body(goals), clock.now() + TWIST_LEAD_S)


class SimWheelServo(STS3215Emulator):
    """An STS3215Emulator whose wheel is one of a sim base's: its goal speed drives the base with the others',
    its speed and angle are the base's measured motion."""

    def __init__(self, servo_id: int, wheels: SimWheels, **kwargs):
        super().__init__(servo_id, **kwargs)
        self.wheels = wheels
        self._t_sim: float | None = None

    def goal_speed(self) -> float:
        """The speed this wheel is told to turn at (steps/s): its goal in wheel mode with torque on, else 0."""
        if not (self.torque_on and self.reg(T.OPERATING_MODE) == T.VELOCITY_MODE):
            return 0.0
        goal = T.decode_sign(self.reg(T.GOAL_VELOCITY), T.SIGN_BITS[T.GOAL_VELOCITY])
        return max(-self.max_speed, min(self.max_speed, float(goal)))

    def update(self, t: float | None = None) -> None:
        self._t = self.clock() if t is None else t
        speed, t_sim = self.wheels.measured(self.id)
        if self._t_sim is not None and t_sim > self._t_sim:
            self.encoder += speed * (t_sim - self._t_sim)
        self._t_sim = t_sim
        self.wheel_speed = self.velocity = speed
        self.load = 0.0

    def write(self, address: int, data: bytes) -> None:
        super().write(address, data)
        if any(address <= a < address + len(data) for a in _DRIVES):
            self.wheels.drive()


def open_sim_wheel_bus(port: str, ids: list[int], timeout: float = 60.0) -> FeetechBusEmulator:
    """Attach to the world's base named in `port` and serve its wheels as servos `ids` (left, back, right)."""
    from .sim import parse_sim_port

    parse_sim_port(port)  # a sim port needs rio-sim: say so, by name, when it is missing
    parsed = parse_sim_base_port(port)
    if parsed is None:
        raise ValueError(f"'{port}' is not a sim port ('sim', 'sim:BASE' or 'sim:BASE@WORLD')")
    from rio_sim.world_base import WorldBase

    base_name, world_name = parsed
    base = WorldBase.attach(world_name, base_name, timeout=timeout)
    try:
        wheels = SimWheels(base, ids)
        bus = FeetechBusEmulator(ids=(), start=False)
        for sid in ids:
            wheels.servos[sid] = bus.servos[sid] = SimWheelServo(sid, wheels)
    except Exception:
        base.close()
        raise
    bus.on_close(base.close)
    return bus.start()
