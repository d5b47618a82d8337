"""A virtual bus whose servos are joints of a rio-sim MuJoCo arm.

`port = "sim"` (or `"sim:ARM"`, `"sim:ARM@WORLD"`; ARM is the scene's arm prefix: arm, left, right)
gives a driver a private `VirtualBus` whose present positions come from a running `sim.world`'s
joints and whose goal positions go to that world's position actuators, through rio-sim's world bus
(shared memory; rio-sim's public node-side API). The driver above it is unchanged: scservo_sdk
packets over a pty, calibration, safety, faults. So a station with a `sim.world` and
`so100.follower` with `port = "sim"` runs the real driver against physics, cameras included.

The calibration is the sim model's: 0 rad at mid-turn, each joint's range from the MJCF; the jaw
servo's range maps linearly onto the finger opening (0 .. the robot's max width).
"""

from __future__ import annotations

import numpy as np

from ..calibration import MID, RAD_PER_STEP, ArmCalibration, JointCalibration
from ..feetech import control_table as T
from ..models import ARM_IDS, ARM_JOINTS, GRIPPER, GRIPPER_ID
from .bus import VirtualBus
from .servo import VirtualServo

#: A goal reaches the world as a target this far ahead (s): the servo's "as fast as you can".
GOAL_LEAD_S = 0.02
_JAW_SPAN = 1200  # steps between closed and fully open jaw


def parse_sim_port(port: str) -> tuple[str, str] | None:
    """'sim' -> ('arm', 'sim'); 'sim:left@w' -> ('left', 'w'); anything else -> None."""
    if port != "sim" and not port.startswith("sim:"):
        return None
    rest = port[4:] if port.startswith("sim:") else ""
    arm, _, world = rest.partition("@")
    return arm or "arm", world or "sim"


class SimJoint:
    """One servo's link to the world: qpos addresses (several for the fingers) and actuators."""

    def __init__(self, world, qpos: np.ndarray, act: np.ndarray, to_steps, from_steps):
        self.world, self.qpos, self.act = world, qpos, act
        self.to_steps, self.from_steps = to_steps, from_steps
        self._buf = {"qpos": np.empty(world.nq), "qvel": np.empty(world.nv), "ctrl": np.empty(world.nu)}

    def position(self) -> float:
        self.world.check_alive()
        return self.to_steps(self.world.read_state(self._buf)["qpos"][self.qpos])

    def command(self, steps: float, t_target: float) -> None:
        targets = self.from_steps(steps)
        self.world.command(self.act, np.broadcast_to(targets, self.act.shape).astype(np.float64), t_target)


class SimServo(VirtualServo):
    """A VirtualServo whose physics is the sim: position read from the world, goals sent to it."""

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


def open_sim_bus(port: str, timeout: float = 60.0) -> tuple[VirtualBus, ArmCalibration]:
    """Attach to the world named in `port` and serve its arm's joints as servos 1-6."""
    from rio_sim.bus import WorldBus
    from rio_sim.indices import arm_indices
    from rio_sim.robots import get_robot
    from rio_sim.scenes import build_model, get_scene

    arm, world_name = parse_sim_port(port)
    world = WorldBus.attach(world_name, timeout=timeout)
    try:
        model = build_model(world.scene)
        robot = get_robot(get_scene(world.scene).arm(arm).robot)
        if tuple(robot.arm_joints) != ARM_JOINTS:
            raise ValueError(f"sim arm '{arm}' is a {robot.name}, not an SO-arm: its joints are {robot.arm_joints}")
        idx = arm_indices(model, arm, robot)
    except Exception:
        world.close()
        raise
    cal = ArmCalibration("so100", "follower", f"sim-{arm}")
    bus = VirtualBus(ids=(), start=False)
    for k, (name, sid) in enumerate(zip(ARM_JOINTS, ARM_IDS, strict=True)):
        lo, hi = model.jnt_range[model.joint(f"{arm}/{name}").id]
        jc = JointCalibration(sid, 0, MID, max(1, MID + int(np.ceil(lo / RAD_PER_STEP))),
                              min(T.STEPS_PER_TURN - 1, MID + int(np.floor(hi / RAD_PER_STEP))))
        cal.joints[name] = jc
        joint = SimJoint(world, idx.qpos[k:k + 1], idx.act[k:k + 1], lambda q: MID + float(q[0]) / RAD_PER_STEP,
                         lambda s: (s - MID) * RAD_PER_STEP)
        bus.servos[sid] = SimServo(sid, joint)
    jaw = JointCalibration(GRIPPER_ID, 0, MID, MID, MID + _JAW_SPAN)
    cal.joints[GRIPPER] = jaw
    width, n = robot.max_width, len(idx.finger_act)
    fingers = SimJoint(world, idx.finger_qpos, idx.finger_act,
                       lambda q: jaw.from_fraction(float(np.sum(q)) / width),
                       lambda s: jaw.fraction(s) * width / n)
    bus.servos[GRIPPER_ID] = SimServo(GRIPPER_ID, fingers)
    bus.on_close(world.close)
    return bus.start(), cal
