"""Optional backends: the joints of a running rio-sim arm (`backend="sim[:ARM[@WORLD]]"`) and a Robotiq
URCap socket (63352) from rio-robotiq's emulator, whose fingers are then the world's. Imported only when
asked for: rio-sim and rio-robotiq stay optional.

Through rio-sim's `WorldArm` (shared memory with the world's process) the controller's 500 Hz setpoint
goes to the simulated arm's position actuators a short lead ahead (the world interpolates it in physics
time) and the joints RTDE reports are the simulated ones, so the real ur-rtde moves physics and the
cameras see it. The gripper's fingers are the simulated fingers: a cube between them stops them, and
the URCap reports an object as a real 2F-85 does.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rio import clock

LEAD_S = 0.02  # a setpoint reaches the world this far ahead (s): the joints' servo lag


class SimJoints:
    """`URRobot`'s joints as the world's arm: each tick's setpoint becomes a target, the reading is physics."""

    def __init__(self, world_arm: Any):
        self.arm = world_arm

    def read(self) -> np.ndarray:
        return self.arm.joint_pos()

    def write(self, q_cmd: np.ndarray, dt: float) -> None:
        self.arm.command_joints(q_cmd, clock.now() + LEAD_S)

    def close(self) -> None:
        self.arm.close()



def attach(backend: str, timeout: float = 120.0) -> tuple[Any, SimJoints]:
    """The world's arm named by `backend` ('sim', 'sim:ARM', 'sim:ARM@WORLD'), waiting for the world."""
    try:
        from rio_sim.world_arm import WorldArm, parse_sim_target
    except ImportError as e:
        raise ImportError(f"backend '{backend}' needs rio-sim: install rio-ur[sim]") from e
    target = parse_sim_target(backend)
    if target is None:
        raise ValueError(f"unknown emulator backend '{backend}': 'model', 'sim', 'sim:ARM' or 'sim:ARM@WORLD'")
    wa = WorldArm.attach(world=target[1], arm=target[0], timeout=timeout)
    if wa.robot.dof != 6:
        wa.close()
        raise ValueError(f"the world's arm '{target[0]}' is a {wa.robot.name} ({wa.robot.dof} joints), not a UR")
    return wa, SimJoints(wa)


def urcap_server(host: str, world_arm: Any = None) -> Any:
    """A Robotiq 2F-85 behind the URCap socket on `host`:63352 (rio-robotiq's emulator); its fingers are
    the world's when there is one."""
    try:
        from rio_robotiq.emulator.registers import RobotiqRegisters
        from rio_robotiq.emulator.urcap import UrcapServer
    except ImportError as e:
        raise ImportError("the URCap socket needs rio-robotiq: install rio-ur[robotiq]") from e
    registers = RobotiqRegisters("2f85")
    if world_arm is not None:
        from rio_sim.world_fingers import SimFingers

        registers.fingers = SimFingers(world_arm)
    return UrcapServer(registers, host=host, port=63352)
