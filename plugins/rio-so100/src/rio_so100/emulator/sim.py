"""An emulated bus whose servos are joints of a rio-sim MuJoCo arm.

`port = "sim"` (or `"sim:ARM"`, `"sim:ARM@WORLD"`; ARM is the scene's arm prefix: arm, left, right)
gives a driver a private `FeetechBusEmulator` whose present positions come from a running `sim.world`'s
joints and whose goal positions go to that world's position actuators, through rio-sim's
`WorldArm` (one arm of a running world, over its shared-memory bus). The driver above it is
unchanged: scservo_sdk packets over a pty, calibration, safety, faults. So a station with a `sim.world` and
`so100.follower` with `port = "sim"` runs the real driver against physics, cameras included.

The calibration is the sim model's: 0 rad at mid-turn, each joint's range from the MJCF; the jaw
servo's range maps linearly onto the finger opening (0 .. the robot's max width).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..calibration import MID, RAD_PER_STEP, ArmCalibration, JointCalibration
from ..feetech import control_table as T
from ..models import ARM_IDS, ARM_JOINTS, GRIPPER, GRIPPER_ID
from .bus import FeetechBusEmulator
from .servo import STS3215Emulator

#: A goal reaches the world as a target this far ahead (s): the servo's "as fast as you can".
GOAL_LEAD_S = 0.02
_JAW_SPAN = 1200  # steps between closed and fully open jaw


def parse_sim_port(port: str) -> tuple[str, str] | None:
    """'sim' -> ('arm', 'sim'); 'sim:left@w' -> ('left', 'w'); anything else -> None (rio-sim's
    `parse_sim_target`; a port that is not a sim port never imports rio-sim)."""
    if port != "sim" and not port.startswith("sim:"):
        return None
    try:
        from rio_sim.world_arm import parse_sim_target
    except ImportError as e:
        raise ImportError(f"port '{port}' needs rio-sim: install rio-so100[sim]") from e
    return parse_sim_target(port)


class SimJoint:
    """One servo's link to the world: how to read its position (rad or m) and command a target."""

    def __init__(self, read: Callable[[], float], write: Callable[[float, float], None],
                 to_steps: Callable[[float], float], from_steps: Callable[[float], float]):
        self.read, self.write = read, write
        self.to_steps, self.from_steps = to_steps, from_steps

    def position(self) -> float:
        return self.to_steps(self.read())

    def command(self, steps: float, t_target: float) -> None:
        self.write(self.from_steps(steps), t_target)


class SimServo(STS3215Emulator):
    """An STS3215Emulator whose physics is the sim: position read from the world, goals sent to it."""

    def __init__(self, servo_id: int, joint: SimJoint, **kwargs):
        super().__init__(servo_id, **kwargs)
        self.joint = joint
        self.encoder = joint.position()

    def update(self, t: float | None = None) -> None:
        t = self.clock() if t is None else t
        before, dt = self.encoder, max(t - self._t, 0.0)
        self._t = t
        self.encoder = self.joint.position() + self.homing_offset
        self.velocity = (self.encoder - before) / dt if dt > 0 else 0.0
        self.load = 0.0

    def write(self, address: int, data: bytes) -> None:
        super().write(address, data)
        touched = range(address, address + len(data))
        if self.torque_on and (T.GOAL_POSITION[0] in touched or T.TORQUE_ENABLE[0] in touched):
            lo, hi = self.reg(T.MIN_POSITION_LIMIT), self.reg(T.MAX_POSITION_LIMIT)
            goal = min(max(self.reg(T.GOAL_POSITION), lo), hi)
            self.joint.command(goal, self.clock() + GOAL_LEAD_S)


def open_sim_bus(port: str, timeout: float = 60.0) -> tuple[FeetechBusEmulator, ArmCalibration]:
    """Attach to the world named in `port` and serve its arm's joints as servos 1-6."""
    from rio_sim.world_arm import WorldArm

    parsed = parse_sim_port(port)
    if parsed is None:
        raise ValueError(f"'{port}' is not a sim port ('sim', 'sim:ARM' or 'sim:ARM@WORLD')")
    arm_name, world_name = parsed
    arm = WorldArm.attach(world_name, arm_name, timeout=timeout)
    try:
        robot, model = arm.robot, arm.model
        if tuple(robot.arm_joints) != ARM_JOINTS:
            raise ValueError(f"sim arm '{arm_name}' is a {robot.name}, not an SO-arm: its joints are "
                             f"{robot.arm_joints}")
        cal = ArmCalibration("so100", "follower", f"sim-{arm_name}")
        bus = FeetechBusEmulator(ids=(), start=False)
        for k, (name, sid) in enumerate(zip(ARM_JOINTS, ARM_IDS, strict=True)):
            lo, hi = model.jnt_range[model.joint(f"{arm_name}/{name}").id]
            jc = JointCalibration(sid, 0, MID, max(1, MID + int(np.ceil(lo / RAD_PER_STEP))),
                                  min(T.STEPS_PER_TURN - 1, MID + int(np.floor(hi / RAD_PER_STEP))))
            cal.joints[name] = jc
            joint = SimJoint(lambda k=k: float(arm.joint_pos()[k]),
                             lambda q, t, k=k: arm.command_joints([q], t, joints=[k]),
                             lambda q: MID + q / RAD_PER_STEP, lambda s: (s - MID) * RAD_PER_STEP)
            bus.servos[sid] = SimServo(sid, joint)
        jaw = JointCalibration(GRIPPER_ID, 0, MID, MID, MID + _JAW_SPAN)
        cal.joints[GRIPPER] = jaw
        width = robot.max_width
        fingers = SimJoint(arm.finger_width, arm.command_width,
                           lambda w: jaw.from_fraction(w / width), lambda s: jaw.fraction(s) * width)
        bus.servos[GRIPPER_ID] = SimServo(GRIPPER_ID, fingers)
    except Exception:
        arm.close()
        raise
    bus.on_close(arm.close)
    return bus.start(), cal
