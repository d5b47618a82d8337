"""An arm's reach from its model: the default workspace box of an arm that ships a robot description.

The box is where the tool can be: forward kinematics of many joint configurations drawn within the joint
limits (seeded, so every start of a node computes the same box), and of the home pose, bounded per axis and
widened by a margin of the largest distance from the base, since draws rarely reach the fully stretched
extremes. It bounds what a wild target can ask (a policy emitting 10^6 m), not where the arm may collide: a
station narrows it with its own `workspace` (a table, a wall).
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: Joint configurations drawn (forward kinematics costs ~30 us each: ~60 ms once, when the node opens).
SAMPLES = 2000
#: The box is widened on every side by this fraction of the largest tool distance from the base.
MARGIN = 0.05


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
