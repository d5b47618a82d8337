"""The fake base driving a rio-sim world's arm (`backend = "sim"` or "sim:ARM@WORLD"): the fake's joint
positions go to the world's arm through `WorldArm` and the measured ones come back from it; the 2F-85's
goal goes to the arm's fingers through rio-sim's `SimFingers`. rio-sim is imported only here, when asked
for: it stays optional (`rio-kinova[sim]`)."""

from __future__ import annotations

from typing import Any

from ..models import ArmModel


def attach(backend: str, model: ArmModel, timeout_s: float) -> Any:
    try:
        from rio_sim.world_arm import WorldArm, parse_sim_target
    except ImportError as e:
        raise ImportError(f"backend '{backend}' needs rio-sim ({e}): pip install 'rio-kinova[sim]'") from None
    target = parse_sim_target(backend)
    if target is None:
        raise ValueError(f"backend '{backend}': write 'sim' or 'sim:ARM@WORLD'")
    arm, world = target
    plant = WorldArm.attach(world, arm, timeout=max(timeout_s, 1.0))
    if len(plant.idx.qpos) != model.dof:
        plant.close()
        raise ValueError(f"world '{world}' arm '{arm}' has {len(plant.idx.qpos)} joints; {model.label} has "
                         f"{model.dof}")
    return plant


def sim_fingers(plant: Any, speed: float) -> Any:
    """The fingers of the world's arm `plant` as a finger model (rio-sim's `SimFingers`): a width goal at
    `speed` (m/s), the opening read back from physics, so what is between them stops them."""
    from rio_sim.world_fingers import SimFingers

    return SimFingers(plant, speed=speed)
