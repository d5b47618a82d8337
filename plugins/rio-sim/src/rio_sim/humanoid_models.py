"""The humanoids rio-sim models, by name: a module each (`rio_sim.g1`, `rio_sim.t1`) with what the one
humanoid driver, the world and the scenes need to know about it (no MuJoCo at import):

- `ASSET` (its MJCF in `assets/`), `asset_text(hands)`, `BASE` (the root body), `FREE_JOINT` (its free
  joint) and `STANDING_HEIGHT` (the root's height with the soles on the floor at home);
- `JOINTS` (the vendor's motor order, which is also the actuators'), `home()` in that order;
- `GAINS` (servo kp, kd per joint group) and `group(joint)`;
- `FRAMES` (the hands' tool sites, "left" and "right", for the wrists' IK) and `IK` (what else that IK
  is asked, merged into the driver's `robot_description()`).
"""

from __future__ import annotations

from types import ModuleType


def get_humanoid(name: str) -> ModuleType:
    """The module of humanoid `name` ("g1" or "t1")."""
    from . import g1, t1

    models = {"g1": g1, "t1": t1}
    if name not in models:
        raise KeyError(f"unknown sim humanoid '{name}'; rio-sim models: {', '.join(models)}")
    return models[name]


def to_servos(spec, robot: ModuleType, mounted: bool) -> None:
    """Turn a humanoid asset's torque motors into joint PD servos at the physics rate (position actuators:
    the target is `ctrl`; kp, kd as in `robot.GAINS` until the drivers send theirs), limited to each
    joint's range and effort; when `mounted`, weld the root (remove its free joint) and feed gravity
    forward, so a held pose does not sag."""
    import mujoco

    for act in spec.actuators:
        kp, kd = robot.GAINS[robot.group(act.target)]
        act.set_to_position(kp=kp, kv=kd)
        act.ctrlrange = spec.joint(act.target).range
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    if not mounted:
        return
    spec.delete(spec.joint(robot.FREE_JOINT))
    for body in spec.bodies:
        body.gravcomp = 1.0
    for joint in spec.joints:
        joint.actgravcomp = True
