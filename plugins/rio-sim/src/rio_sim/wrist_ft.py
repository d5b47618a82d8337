"""Each sim arm's wrist force/torque sensor: a site `<arm>/ft` at the origin of the body that carries the
tool (the flange side of the gripper), with MuJoCo `force` and `torque` sensors on it, added to every
arm of every scene (`rio_sim.scenes.build_spec`), so no robot's MJCF needs one of its own.

What they measure (MuJoCo's convention): the interaction force and torque between the tool's subtree (the
gripper, its fingers, whatever they touch) and the wrist, expressed in the site's frame. At rest and
touching nothing that is the gripper's weight (about 3 N for the xArm7's 0.32 kg gripper): tare it. The
world publishes every sensor value on its bus (`rio_sim.bus`), so `sim.wrench` and the arm's force limit
read them without stepping physics themselves."""

from __future__ import annotations

import numpy as np

SITE = "ft"


def site_name(arm: str) -> str:
    return f"{arm}/{SITE}"


def add_wrist_ft(spec, arm: str, tool_site: str) -> None:
    """Add `<arm>/ft` and its force and torque sensors to an MjSpec whose arm `arm` is attached already."""
    import mujoco

    body = spec.site(f"{arm}/{tool_site}").parent
    body.add_site(name=site_name(arm), pos=[0.0, 0.0, 0.0], size=[0.006, 0.0, 0.0], group=4)
    for kind, sensor in (("force", mujoco.mjtSensor.mjSENS_FORCE), ("torque", mujoco.mjtSensor.mjSENS_TORQUE)):
        spec.add_sensor(name=f"{site_name(arm)}_{kind}", type=sensor, objtype=mujoco.mjtObj.mjOBJ_SITE,
                        objname=site_name(arm))


def wrist_ft_indices(model, arm: str) -> np.ndarray:
    """Where `<arm>`'s wrist force (3) and torque (3) are in `sensordata`."""
    try:
        f, t = (int(model.sensor(f"{site_name(arm)}_{k}").adr[0]) for k in ("force", "torque"))
    except KeyError:
        raise KeyError(f"the scene has no wrist force/torque sensor on arm '{arm}'") from None
    return np.r_[f:f + 3, t:t + 3]
