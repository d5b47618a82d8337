"""`teleop.expert`: a scripted expert for a sim station's pick-and-place task, as a teleop device, so
`rio teleop sim-so100 --teleop expert --record D --episodes 50` records demonstrations from varied starts,
headless and unattended, through exactly the path a person's device takes (twist, gripper, buttons).

It reads the world's privileged state from the world bus (every joint, the cubes' and pads' true poses,
the episode's start and time limit that a task writes there) and runs one `rio_sim.expert_plan.ArmPlan`
per arm of the scene's pick-and-place pairs. It publishes, besides the standard keys, `twists` (one row
per arm, each in that arm's base frame) and `grippers`, which the twist teleop applies arm by arm
(`rio.teleop.twist`), and `phases` (each arm's phase, an index into `expert_plan.PHASES`). It drives in
translation_rotation mode (`default_mode`): it turns the fingers square to the cube.

It ends the episode itself: done + keep once every cube rests on its pad, released (the task's own
predicate, `rio_sim.success`, on its copy of the state) for `HOLD_S`; done + discard when the task's
time limit is `give_up_s` away (before the loop's own end at the limit, so the verdict is the device's)
or when every arm has given up. Before the control loop calls `reset()` (at the episode's start) it
holds still.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from pydantic import Field

from rio.control.teleop import BUTTON_DISCARD, BUTTON_DONE, BUTTON_KEEP
from rio.interfaces import TeleopNode
from rio.runtime.node import remote

from .attached import WorldAttachment
from .expert_plan import PHASES, ArmPlan, View

#: Success must hold this long (simulated s) before the expert says keep.
HOLD_S = 0.3


class WorldReader:
    """The state each arm's plan reads, from a world's qpos/qvel (a copy of the scene, kinematics only)."""

    def __init__(self, model: Any, scene: Any, arms: list[str] | None = None):
        import mujoco

        from .robots import get_robot
        from .success import PickPlaceJudge

        self._mj, self.model, self.scene = mujoco, model, scene
        self.data = mujoco.MjData(model)
        pairs = {arm: (cube, pad) for arm, cube, pad in scene.pick_place}
        self.arms = list(arms) if arms else [a for a, _, _ in scene.pick_place]
        if not self.arms:
            raise ValueError(f"scene '{scene.name}' has no pick-and-place objects for the expert to move")
        unknown = [a for a in self.arms if a not in pairs]
        if unknown:
            raise ValueError(f"arms: scene '{scene.name}' has no pick-and-place for {unknown}; "
                             f"arms with one: {list(pairs)}")
        self.judge = PickPlaceJudge(model, scene)
        self.pair_of = {p.arm: i for i, p in enumerate(self.judge.pairs)}
        self.mounts = [scene.arm(a) for a in self.arms]
        self.sites = [model.site(f"{a}/{get_robot(m.robot).tool_site}").id for a, m in zip(self.arms, self.mounts,
                                                                                          strict=True)]
        self.fingers = [[model.joint(f"{a}/{j}").qposadr[0] for j in get_robot(m.robot).finger_joints]
                        for a, m in zip(self.arms, self.mounts, strict=True)]
        self.objects = [(model.joint(pairs[a][0]).qposadr[0], model.joint(pairs[a][1]).qposadr[0]) for a in self.arms]

    def views(self, t: float, qpos: np.ndarray, qvel: np.ndarray) -> list[View]:
        d = self.data
        d.qpos[:], d.qvel[:] = qpos, qvel
        self._mj.mj_forward(self.model, d)  # kinematics and contacts (the judge's "released")
        placed = self.judge.placed(d)
        out = []
        for i, arm in enumerate(self.arms):
            x_axis = d.site_xmat[self.sites[i]].reshape(3, 3)[:, 0]  # the fingers close along the tool's x
            cube, pad = self.objects[i]
            out.append(View(t, d.site_xpos[self.sites[i]].copy(), math.atan2(x_axis[1], x_axis[0]),
                            float(np.sum(d.qpos[self.fingers[i]])), d.qpos[cube:cube + 7].copy(),
                            d.qpos[pad:pad + 7].copy(), placed[self.pair_of[arm]]))
        return out

    def to_base(self, i: int, twist_world: np.ndarray) -> np.ndarray:
        """A world-frame twist in arm i's base frame (mounts turn about the vertical only)."""
        c, s = math.cos(self.mounts[i].yaw), math.sin(self.mounts[i].yaw)
        r = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        return np.concatenate([r @ twist_world[:3], r @ twist_world[3:]])


class SimExpert(TeleopNode):
    default_mode: ClassVar[str] = "translation_rotation"

    class Config(TeleopNode.Config):
        buttons: int = Field(4, ge=4, le=64, description="buttons published (done, keep and discard among them)")
        world: str = Field("sim", description="the sim.world whose task it performs")
        arms: list[str] = Field(default_factory=list, description="the scene's arms it drives, in the station's "
                                                                  "arm role order (default: every arm with a "
                                                                  "pick-and-place pair, in the scene's order)")
        give_up_s: float = Field(1.0, ge=0, description="say discard this long before the task's time limit")
        rate_hz: float = Field(100.0, gt=0)

    def setup(self) -> None:
        super().setup()
        self.sim = WorldAttachment(self.config.world)
        self.reader: WorldReader | None = None
        self.plans: list[ArmPlan] = []
        self.started = False
        self.t_success: float | None = None
        # one row per arm the station can have (arm, arm2); rows past the scene's arms stay zero
        n = max(len(self.config.arms), 2)
        self.example_data = {**self.example_data, "twists": np.zeros((n, 6)), "grippers": np.ones(n),
                             "phases": np.zeros(n, np.int64)}

    def open(self) -> None:
        from .scenes import get_scene

        self.sim.attach()
        self.reader = WorldReader(self.sim.model, get_scene(self.sim.bus.scene), self.config.arms or None)
        if len(self.reader.arms) > len(self.example_data["grippers"]):
            raise ValueError(f"arms: {len(self.reader.arms)} arms, at most {len(self.example_data['grippers'])}")

    def close(self) -> None:
        self.sim.detach()

    @remote
    def reset(self) -> float:
        """Start the task from the world's state now (the control loop calls it at the episode's start).
        Returns 0: the expert has no fixed length, it ends the episode itself."""
        self.plans = [ArmPlan() for _ in self.reader.arms]
        self.started, self.t_success = True, None
        return 0.0

    def read_state(self) -> dict[str, Any]:
        n = len(self.example_data["grippers"])
        twists, grippers, phases = np.zeros((n, 6)), np.ones(n), np.zeros(n, np.int64)
        buttons = np.zeros(self.config.buttons, bool)
        if self.started:
            s = self.sim.state()
            t = float(s["sim_time"])
            views = self.reader.views(t, s["qpos"], s["qvel"])
            for i, (plan, view) in enumerate(zip(self.plans, views, strict=True)):
                tw, grippers[i] = plan.step(view)
                twists[i] = self.reader.to_base(i, tw)
                phases[i] = PHASES.index(plan.phase)
            verdict = self._verdict(t, all(v.placed for v in views))
            if verdict is not None:
                buttons[BUTTON_DONE] = True
                buttons[BUTTON_KEEP if verdict == "keep" else BUTTON_DISCARD] = True
        return {"twist": twists[0], "gripper": float(grippers[0]), "buttons": buttons, "twists": twists,
                "grippers": grippers, "phases": phases}

    def _verdict(self, t: float, placed: bool) -> str | None:
        if placed:
            self.t_success = t if self.t_success is None else self.t_success
            if t - self.t_success >= HOLD_S:
                return "keep"
        else:
            self.t_success = None
        number, t0, limit = self.sim.bus.read_episode()
        if number and limit > 0 and t - t0 >= limit - self.config.give_up_s:
            return "discard"
        if all(p.done for p in self.plans) and not placed:
            return "discard"  # every arm gave up
        return None
