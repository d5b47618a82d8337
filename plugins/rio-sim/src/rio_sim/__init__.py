"""rio-sim: MuJoCo stations, so every RIO workflow runs on a laptop and in CI.

How a simulated station is put together
---------------------------------------
One physics world per station, shared by every node of the station:

    [components.world_sensor]  driver = "sim.world"    scene = "so100"        <- steps physics
    [components.arm]           driver = "sim.arm"      robot = "so100"        <- joints, eef, IK
    [components.gripper]       driver = "sim.gripper"  robot = "so100"        <- finger opening
    [components.front_camera]  driver = "sim.camera"   camera = "front"      <- renders RGB(-D)

- `sim.world` (`rio_sim.world.SimWorld`) is the only node that steps MuJoCo. The station starts it
  like any other node (it is a `*_sensor` role: it publishes the simulated time and the ground-truth
  pose of every object), in its own process under process middlewares.
- The arm, gripper and camera nodes find their world by name (`world = "sim"`, the default)
  through a small shared-memory block, the world bus (`rio_sim.bus`): the world writes joint
  positions and velocities there after every physics batch; each arm or gripper writes timed
  targets for the actuators it owns, which the world interpolates in physics time. So arm, gripper
  and cameras always see one consistent world, whichever middleware the station uses (thread, shm,
  zmq or zenoh; all on one machine).
- Every node compiles the same scene from its name (`rio_sim.scenes`), so indices agree without
  sending a model between processes; cameras render their own copy of it, in parallel.

The drivers implement the standard interfaces (`rio.interfaces.ArmNode`, `GripperNode`,
`CameraNode`), so a control loop, an embodiment or a recorder cannot tell them from hardware.
"""

from __future__ import annotations

from .gl import default_backend as _default_backend
from .session import session_id as _session_id

_default_backend()  # MUJOCO_GL=egl on Linux with libEGL, unless set: headless rendering, no display needed
_session_id()       # before any node process is spawned, so they all inherit it

__all__: list[str] = []
