"""Which geoms of a model multi-frame IK keeps apart, and mink's collision-avoidance limit on them.

A teleop target through the torso, or two hands crossing, would otherwise drive the arms into the body:
the IK follows the target, not the geometry. mink's `CollisionAvoidanceLimit` bounds, each iteration, how
fast two geoms may approach so they stay `min_distance` apart; this module chooses the pairs and guards
each step where that linear bound falls short (`SelfCollision`).

Collision geoms: those with a non-zero `contype` or `conaffinity` (a model's collision geometry; visual
meshes are usually 0/0 and are detailed, slow to measure). In a model with none of those (visual geoms
only) every geom is used. Geoms of the world body (the floor) and planes are never used: the IK keeps
the robot off itself, not off its scene.

Default pairs, from the model's tree: each frame's limb is the subtree below the nearest ancestor of the
frame where the tree branches into several jointed subtrees (a shoulder below the torso); frames on one
limb share it. Each limb's geoms are paired with every other limb's and with the rest of the robot
(torso, pelvis, head, legs). Named pairs replace them (`collision_pairs` in the description: groups of
geom names, or body names standing for that body's collision geoms, or all its geoms if none collide:
naming a geom is how to use a visual one). Either way, geoms on one body, or
on parent and child bodies, are never paired (they touch at their joint), nor are geoms closer than
`min_distance` in the home pose (they always are: avoiding them would lock the limb).

The IK's model is its own copy, never simulated: mink skips pairs whose `contype` / `conaffinity` do
not match (a simulator's contact filter, e.g. G1's arms that never collide with each other), so the
chosen geoms get 1 / 1 there.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from rio.kinematics.base import require

_FAR = 1.0  # m: farther than this counts as "far" when reporting clearance
#: m: how far inside `min_distance` a pair may slip while sliding along: a slide along a curved surface
#: always loses a little distance, and no slack at all would make limbs stick where they touch
SLIP = 1e-3


def collision_geoms(model: Any) -> np.ndarray:
    """Mask of the geoms self-collision may use (see the module docstring for the rule)."""
    mujoco = require("mujoco", "mujoco")
    flat = np.isin(model.geom_type, [int(mujoco.mjtGeom.mjGEOM_PLANE), int(mujoco.mjtGeom.mjGEOM_HFIELD)])
    robot = (model.geom_bodyid != 0) & ~flat
    colliding = robot & ((model.geom_contype != 0) | (model.geom_conaffinity != 0))
    return colliding if colliding.any() else robot


def _children(model: Any) -> list[list[int]]:
    out: list[list[int]] = [[] for _ in range(model.nbody)]
    for b in range(1, model.nbody):
        out[int(model.body_parentid[b])].append(b)
    return out


def _subtree(children: list[list[int]], root: int) -> set[int]:
    out, todo = set(), [root]
    while todo:
        b = todo.pop()
        out.add(b)
        todo.extend(children[b])
    return out


def limbs(model: Any, frame_bodies: Iterable[int]) -> list[set[int]]:
    """The bodies of each frame's limb (overlapping limbs merged into one)."""
    children = _children(model)
    jointed = [bool(model.body_jntnum[list(_subtree(children, b))].sum()) for b in range(model.nbody)]
    out: list[set[int]] = []
    for body in frame_bodies:
        b = int(body)
        while True:
            parent = int(model.body_parentid[b])
            if parent == 0 or sum(jointed[c] for c in children[parent]) > 1:
                break
            b = parent
        limb = _subtree(children, b)
        for other in [o for o in out if o & limb]:
            out.remove(other)
            limb |= other
        out.append(limb)
    return out


def _touching_at_joint(model: Any, a: int, b: int) -> bool:
    """Same rigid body (weld), or parent and child: such geoms meet at their joint."""
    wa, wb = (int(model.body_weldid[model.geom_bodyid[g]]) for g in (a, b))
    return wa == wb or int(model.body_weldid[model.body_parentid[wa]]) == wb \
        or int(model.body_weldid[model.body_parentid[wb]]) == wa


def _pairs(model: Any, groups: Iterable[tuple[Iterable[int], Iterable[int]]]) -> list[tuple[int, int]]:
    out = set()
    for first, second in groups:
        for a in first:
            for b in second:
                if a != b and not _touching_at_joint(model, a, b):
                    out.add((min(a, b), max(a, b)))
    return sorted(out)


def default_pairs(model: Any, frame_bodies: Iterable[int]) -> list[tuple[int, int]]:
    """Geom pairs: each limb against the others and against the rest of the robot."""
    usable = [int(g) for g in np.flatnonzero(collision_geoms(model))]
    parts = limbs(model, frame_bodies)
    geoms = [[g for g in usable if int(model.geom_bodyid[g]) in limb] for limb in parts]
    in_limb = set().union(*parts)
    rest = [g for g in usable if int(model.geom_bodyid[g]) not in in_limb]
    groups = [(g, rest) for g in geoms]
    groups += [(geoms[i], geoms[j]) for i in range(len(geoms)) for j in range(i + 1, len(geoms))]
    return _pairs(model, groups)


def named_pairs(model: Any, spec: Any) -> list[tuple[int, int]]:
    """Geom pairs from `[[[names...], [names...]], ...]`; a name is a geom's, else a body's (its collision
    geoms, or all its geoms when it has none that collide)."""
    mujoco = require("mujoco", "mujoco")
    usable = collision_geoms(model)

    def geoms(i: int, names: Any) -> list[int]:
        if isinstance(names, str) or not isinstance(names, (list, tuple)):
            raise ValueError(f"collision_pairs[{i}]: write two lists of geom or body names, not {names!r}")
        out = []
        for name in names:
            g = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, str(name))
            if g >= 0:
                out.append(g)
                continue
            b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, str(name))
            if b < 0:
                raise ValueError(f"collision_pairs[{i}]: '{name}' is neither a geom nor a body of the model")
            own = np.flatnonzero(model.geom_bodyid == b)
            out += [int(g) for g in (own[usable[own]] if usable[own].any() else own)]
        return out

    if not isinstance(spec, (list, tuple)):
        raise ValueError(f"collision_pairs: write a list of [[names...], [names...]] pairs, not {spec!r}")
    groups = []
    for i, pair in enumerate(spec):
        if not isinstance(pair, (list, tuple)) or len(pair) != 2:
            raise ValueError(f"collision_pairs[{i}]: write two lists of geom or body names, not {pair!r}")
        groups.append((geoms(i, pair[0]), geoms(i, pair[1])))
    return _pairs(model, groups)


def distances(model: Any, data: Any, pairs: Iterable[tuple[int, int]], distmax: float = _FAR) -> np.ndarray:
    """Signed distance of each pair (m; negative: penetrating) in `data`'s pose, `distmax` where farther."""
    mujoco = require("mujoco", "mujoco")
    return np.array([mujoco.mj_geomDistance(model, data, a, b, distmax, None) for a, b in pairs], dtype=np.float64)


class SelfCollision:
    """The pairs kept apart and how: a mink limit (pass it among `solve_ik`'s limits) plus two guards on
    each step, because the limit is linear and sees only pairs nearer than `detection_distance`:
    `overshoot` tells how much longer a step was than half the margin (after which no unseen pair can
    reach `min_distance`), and `kept_apart` rejects a step after which a seen pair ends nearer than
    `min_distance` - `SLIP` (or nearer than it was, if it already was): sliding along a curved surface
    loses distance the linear limit does not see, and over many teleop cycles that would add up to contact.

    Pairs closer than `min_distance` at `home_qpos` are dropped. Sets the chosen geoms' contype /
    conaffinity to 1 in `model` (see the module docstring)."""

    def __init__(self, model: Any, pairs: list[tuple[int, int]], home_qpos: np.ndarray, min_distance: float,
                 detection_distance: float):
        mujoco, mink = require("mujoco", "mujoco"), require("mink", "mink")
        if not 0.0 <= min_distance < detection_distance:
            raise ValueError(f"min_distance {min_distance} and detection_distance {detection_distance}: need "
                             "0 <= min_distance < detection_distance")
        self.model, self.min_distance, self.detection_distance = model, min_distance, detection_distance
        data = mujoco.MjData(model)
        data.qpos[:] = home_qpos
        mujoco.mj_kinematics(model, data)
        self.pairs = [p for p, d in zip(pairs, distances(model, data, pairs, min_distance + 1e-3), strict=True)
                      if d >= min_distance]
        used = sorted({g for p in self.pairs for g in p})
        model.geom_contype[used] = 1
        model.geom_conaffinity[used] = 1
        self._limit = mink.CollisionAvoidanceLimit(model, [([a], [b]) for a, b in self.pairs],
                                                   minimum_distance_from_collisions=min_distance,
                                                   collision_detection_distance=detection_distance)
        self._geoms = np.array(used, dtype=int)
        self._max_travel = 0.5 * (detection_distance - min_distance)
        self._near: list[tuple[int, int]] = []
        self._before = np.zeros(0)
        self._xpos, self._xmat = np.zeros((len(used), 3)), np.zeros((len(used), 9))

    def compute_qp_inequalities(self, configuration: Any, dt: float) -> Any:
        """mink's rows for the pairs within detection distance only: it writes one per pair, most of them
        unbounded, and the QP's cost grows with its rows (G1: 330 pairs, a handful near)."""
        c = self._limit.compute_qp_inequalities(configuration, dt)
        near = np.flatnonzero(np.isfinite(c.h))
        self._near = [self._limit.geom_id_pairs[i] for i in near]
        data = configuration.data
        self._before = distances(self.model, data, self._near, self.detection_distance)
        self._xpos, self._xmat = data.geom_xpos[self._geoms].copy(), data.geom_xmat[self._geoms].copy()
        return type(c)(G=c.G[near], h=c.h[near]) if near.size else type(c)()

    def overshoot(self, data: Any) -> float:
        """How many times half the margin the pairs' geoms moved since the limit's rows (above 1: too far).
        A geom moves by its centre's shift plus its turn (rad) times its bounding radius."""
        shift = np.linalg.norm(data.geom_xpos[self._geoms] - self._xpos, axis=1)
        cos = (np.einsum("ij,ij->i", data.geom_xmat[self._geoms], self._xmat) - 1.0) / 2.0
        turn = np.arccos(np.clip(cos, -1.0, 1.0)) * self.model.geom_rbound[self._geoms]
        return float((shift + turn).max(initial=0.0)) / self._max_travel

    def kept_apart(self, data: Any) -> bool:
        """Whether the pairs seen before the step are still apart in `data`'s pose (see the class)."""
        after = distances(self.model, data, self._near, self.detection_distance)
        return bool(np.all(after >= np.minimum(self._before, self.min_distance - SLIP) - 1e-9))
