"""The emulator's joints and fingers as those of an arm in a running rio-sim world (`backend="sim"`,
`"sim:ARM"` or `"sim:ARM@WORLD"`).

Through rio-sim's `WorldArm` (shared memory with the world's process), the controller's setpoint goes
to the simulated arm's position actuators a short lead ahead (the world interpolates it in physics
time) and the joints the controller reports are the simulated ones, so the real driver, through the
unmodified SDK, moves physics (and the cameras see it). The fingers of whatever tool is configured
are the simulated fingers: an object in the scene stops them.

rio-sim is optional: importing it happens only for a sim backend.
"""

from __future__ import annotations

import numpy as np

from rio import clock

#: A setpoint reaches the world as a target this far ahead (s): the joints' servo lag.
LEAD_S = 0.02
#: Resend an unchanged setpoint this often (s), so the world's target never goes stale.
REFRESH_S = 0.1


def parse_backend(backend: str) -> tuple[str, str] | None:
    """'model' -> None; 'sim' / 'sim:ARM' / 'sim:ARM@WORLD' -> (arm, world) (rio-sim's own parser,
    `rio_sim.world_arm.parse_sim_target`); anything else raises ValueError."""
    if backend == "model":
        return None
    if backend != "sim" and not backend.startswith("sim:"):
        raise ValueError(f"unknown emulator backend '{backend}': 'model', 'sim', 'sim:ARM' or 'sim:ARM@WORLD'")
    try:
        from rio_sim.world_arm import parse_sim_target
    except ImportError as e:
        raise ImportError(f"backend '{backend}' needs rio-sim: install rio-ufactory[sim]") from e
    target = parse_sim_target(backend)
    assert target is not None
    return target


def attach(arm_name: str, world: str, axis: int, model_label: str, timeout: float = 60.0):
    """The world's arm `arm_name`, checked to have `axis` joints."""
    from rio_sim.world_arm import WorldArm

    wa = WorldArm.attach(world=world, arm=arm_name, timeout=timeout)
    joints = list(wa.robot.arm_joints)
    if len(joints) != axis:
        wa.close()
        raise ValueError(f"sim world '{world}' arm '{arm_name}' is a {wa.robot.name} with {len(joints)} joints "
                         f"({', '.join(joints)}); the emulated {model_label} has {axis}")
    return wa


class SimJoints:
    """A `motion.JointBackend` on a `WorldArm`."""

    def __init__(self, world_arm):
        self.arm = world_arm
        self._sent: np.ndarray | None = None
        self._t_sent = 0.0

    def read(self) -> np.ndarray:
        return self.arm.joint_pos()

    def write(self, q_cmd: np.ndarray, t: float, dt: float) -> None:
        now = clock.now()
        if self._sent is None or float(np.abs(q_cmd - self._sent).max()) > 1e-7 or now - self._t_sent > REFRESH_S:
            self.arm.command_joints(q_cmd, now + LEAD_S)
            self._sent, self._t_sent = np.array(q_cmd, dtype=float), now

    def close(self) -> None:
        self.arm.close()
