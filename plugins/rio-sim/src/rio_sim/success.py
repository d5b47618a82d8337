"""The pick-and-place success predicate, computed from the world's state: every cube of the scene's
pick-and-place pairs rests on its pad and is released.

- on the pad: the cube's center lies over the pad's square (in the pad's frame);
- resting: its center at the height it rests at on the table (within `REST_TOLERANCE_M`, so a cube
  held above the pad or tipped onto an edge is not placed) and nearly still (`STILL_M_S`);
- released: no geom of a robot touches it (a cube pinched between open-looking fingers is still held).

`PickPlaceJudge` finds the indices once per compiled model, then judges a `mujoco.MjData` whose contacts
are up to date (after `mj_step` or `mj_forward`), cheaply enough for every physics batch of the world.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: How far the cube's center may be from its resting height on the table (m).
REST_TOLERANCE_M = 0.004
#: The cube's speed below which it counts as resting (m/s).
STILL_M_S = 0.05


@dataclass(frozen=True)
class _Pair:
    arm: str
    cube: str
    pad: str
    cube_qpos: int
    cube_dof: int
    cube_geom: int
    rest_z: float
    pad_qpos: int
    pad_half: tuple[float, float]


class PickPlaceJudge:
    def __init__(self, model, scene):
        pairs = []
        for arm, cube, pad in scene.pick_place:
            c, p = model.joint(cube), model.joint(pad)
            pad_obj = scene.object(pad)
            pairs.append(_Pair(arm, cube, pad, int(c.qposadr[0]), int(c.dofadr[0]), int(model.geom(cube).id),
                               float(scene.object(cube).pos[2]), int(p.qposadr[0]),
                               (float(pad_obj.size[0]), float(pad_obj.size[1]))))
        self.pairs = tuple(pairs)
        prefixes = tuple(f"{a.name}/" for a in scene.arms) + ((f"{scene.humanoid.name}/",) if scene.humanoid else ())
        self.robot_geoms = frozenset(g for g in range(model.ngeom)
                                     if model.body(int(model.geom_bodyid[g])).name.startswith(prefixes))

    def held(self, data, pair: _Pair) -> bool:
        """Whether a robot touches the pair's cube."""
        for i in range(data.ncon):
            c = data.contact[i]
            g1, g2 = int(c.geom1), int(c.geom2)
            if (g1 == pair.cube_geom and g2 in self.robot_geoms) or (g2 == pair.cube_geom and g1 in self.robot_geoms):
                return True
        return False

    def placed(self, data) -> list[bool]:
        """For each pair, whether its cube rests on its pad, released."""
        out = []
        for p in self.pairs:
            cube, pad = data.qpos[p.cube_qpos:p.cube_qpos + 3], data.qpos[p.pad_qpos:p.pad_qpos + 7]
            qw, qz = pad[3], pad[6]
            yaw = 2.0 * np.arctan2(qz, qw)  # pads turn about the vertical only
            d = cube[:2] - pad[:2]
            c, s = np.cos(yaw), np.sin(yaw)
            local = (c * d[0] + s * d[1], -s * d[0] + c * d[1])
            over = abs(local[0]) <= p.pad_half[0] and abs(local[1]) <= p.pad_half[1]
            resting = abs(cube[2] - p.rest_z) < REST_TOLERANCE_M
            still = float(np.linalg.norm(data.qvel[p.cube_dof:p.cube_dof + 3])) < STILL_M_S
            out.append(bool(over and resting and still and not self.held(data, p)))
        return out

    def __call__(self, data) -> bool:
        return bool(self.pairs) and all(self.placed(data))
