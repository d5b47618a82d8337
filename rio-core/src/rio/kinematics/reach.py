"""An arm's reach from its model: the default workspace box of an arm that ships a robot description.

The box is where the tool can be: forward kinematics of many joint configurations drawn within the joint
limits (seeded, so every start of a node computes the same box), and of the home pose, bounded per axis and
widened by a margin of the largest distance from the base, since draws rarely reach the fully stretched
extremes. It bounds what a wild target can ask (a policy emitting 10^6 m), not where the arm may collide: a
station narrows it with its own `workspace` (a table, a wall).

Without a solver (an arm installed without its plugin's `[ik]` extra, driven through its controller's own
Cartesian control) the box comes from the model table instead: `reach_box_from_table`, around the vendor's
published reach (`rio.interfaces.ModelTable.reach`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: Joint configurations drawn (forward kinematics costs ~30 us each: ~60 ms once, when the node opens).
SAMPLES = 2000
#: The box is widened on every side by this fraction of the largest tool distance from the base.
MARGIN = 0.05
#: A published reach is measured to the wrist (the centre of the last joints): the flange and a short tool
#: stick out up to ~20% farther (UR3e: 0.59 m at the flange for 0.50 m published), so the box from a
#: published reach is this much larger than the reach.
REACH_SLACK = 0.25


def reach_box(solver: Any, home: Any = None, samples: int = SAMPLES, margin: float = MARGIN,
              seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) corners (m, the model's base frame) of the box around every tool position `solver`'s
    joints reach (`solver`: an `IKSolver`, its `fk`, `random_q` and joint limits), `home` included."""
    rng = np.random.default_rng(seed)
    points = [np.asarray(solver.fk(solver.random_q(rng)), dtype=np.float64)[:3] for _ in range(samples)]
    if home is not None:
        points.append(np.asarray(solver.fk(solver.clip(home)), dtype=np.float64)[:3])
    p = np.array(points)
    pad = margin * float(np.linalg.norm(p, axis=1).max())
    return p.min(axis=0) - pad, p.max(axis=0) + pad


def reach_box_from_table(reach: float, shoulder_height: float = 0.0,
                         slack: float = REACH_SLACK) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) corners (m, base frame) of the cube around the sphere the tool stays in by the vendor's
    published `reach` (m), centred on the shoulder (`shoulder_height` m above the base), widened by `slack`.
    Needs no solver: what bounds an arm installed without IK."""
    if not reach > 0:
        raise ValueError(f"reach {reach!r}: a published reach is a positive distance (m)")
    r = reach * (1.0 + slack)
    centre = np.array([0.0, 0.0, float(shoulder_height)])
    return centre - r, centre + r
