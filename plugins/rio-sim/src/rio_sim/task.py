"""A sim station's task: where its objects start at each episode (drawn from a seeded distribution),
when the episode counts as a success, and how long it may last.

Declared in the station file under the world component, so the world node that moves the objects also
validates what it is told to do:

    [components.world_sensor]
    driver = "sim.world"
    scene = "so100"

    [components.world_sensor.task]
    seed = 0                 # episode k starts from the draw of seed (seed, k)
    time_limit_s = 30        # of simulated time

    [components.world_sensor.task.start.cube]   # world frame: x forward, y left, the table top z = 0
    x = [0.16, 0.24]
    y = [0.02, 0.10]
    yaw = [-3.1416, 3.1416]

    [components.world_sensor.task.start.pad]
    x = [0.16, 0.24]
    y = [-0.10, -0.02]

The task is the scene's pick-and-place (`Scene.pick_place`): every cube on its pad, released. Objects
without a `start` table stay where the scene puts them. Episode k of a run seeded `seed` draws its start
from `numpy.random.SeedSequence([seed, k])`, so a run is reproducible episode by episode, and a second
session recording into the same dataset (whose episodes continue the numbering) gets new starts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from pydantic import Field, field_validator

from rio.config import Config

#: Draws tried before giving up on placing the objects apart.
MAX_DRAWS = 1000


class ObjectStart(Config):
    """Where one object starts: each coordinate uniform in its [low, high] range; a coordinate left out
    keeps the scene's value (yaw: 0)."""

    x: tuple[float, float] | None = Field(None, description="world x range (m)")
    y: tuple[float, float] | None = Field(None, description="world y range (m)")
    yaw: tuple[float, float] | None = Field(None, description="rotation about the vertical (rad)")

    @field_validator("x", "y", "yaw")
    @classmethod
    def _ordered(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and not (math.isfinite(v[0]) and math.isfinite(v[1]) and v[0] <= v[1]):
            raise ValueError(f"a range is [low, high] with low <= high, got {list(v)}")
        return v


class TaskConfig(Config):
    """A sim world's task (see the module docstring)."""

    kind: str = Field("pick_place", description="pick_place: every cube of the scene on its pad, released")
    seed: int = Field(0, ge=0, description="the run's seed; episode k starts from the draw of (seed, k)")
    time_limit_s: float = Field(30.0, gt=0, description="an episode ends unsuccessful after this much "
                                                        "simulated time")
    start: dict[str, ObjectStart] = Field(default_factory=dict,
                                          description="start ranges per object (objects not named stay put)")
    min_distance_m: float = Field(0.07, ge=0, description="least distance between the centers of an object "
                                                          "placed by the task and any other object")

    @field_validator("kind")
    @classmethod
    def _known(cls, v: str) -> str:
        if v != "pick_place":
            raise ValueError(f"unknown task kind '{v}'; kinds: pick_place")
        return v


def check_task(task: TaskConfig, scene: Any) -> None:
    """Raise ValueError (naming the field) where `task` does not fit `scene` (a `rio_sim.scenes.Scene`)."""
    if task.kind == "pick_place" and not scene.pick_place:
        raise ValueError(f"task.kind: scene '{scene.name}' has no pick-and-place objects")
    free = [o.name for o in scene.free_objects]
    for name in task.start:
        if name not in free:
            raise ValueError(f"task.start.{name}: scene '{scene.name}' has no movable object '{name}'; "
                             f"objects: {', '.join(free)}")


def episode_seed(seed: int, episode: int) -> int:
    """The seed episode `episode` of a run seeded `seed` draws its start from (a 32-bit integer)."""
    import numpy as np

    return int(np.random.SeedSequence([int(seed), int(episode)]).generate_state(1)[0])


@dataclass
class EpisodeStart:
    seed: int
    episode: int
    episode_seed: int
    #: object name -> pose [x, y, z, qw, qx, qy, qz] (world frame) for every object the task placed
    poses: dict[str, list[float]]

    def to_json(self) -> dict[str, Any]:
        return {"seed": self.seed, "episode": self.episode, "episode_seed": self.episode_seed,
                "start": {k: [round(float(x), 6) for x in v] for k, v in self.poses.items()}}


def yaw_quat(yaw: float) -> list[float]:
    return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]


def sample_start(task: TaskConfig, scene: Any, seed: int, episode: int) -> EpisodeStart:
    """The start of episode `episode` of a run seeded `seed`: a pose for every object in `task.start`,
    each within its ranges, every one at least `min_distance_m` from every other object (drawn again
    until they are; ValueError after `MAX_DRAWS` tries)."""
    import numpy as np

    s = episode_seed(seed, episode)
    rng = np.random.default_rng(s)
    names = [o.name for o in scene.objects if o.name in task.start]  # the scene's order, not the table's
    fixed = {o.name: np.asarray(o.pos[:2]) for o in scene.objects if o.free and o.name not in task.start}
    for _ in range(MAX_DRAWS):
        placed: dict[str, np.ndarray] = {}
        yaws: dict[str, float] = {}
        for name in names:
            rule, pos = task.start[name], scene.object(name).pos
            x = rng.uniform(*rule.x) if rule.x is not None else pos[0]
            y = rng.uniform(*rule.y) if rule.y is not None else pos[1]
            yaws[name] = float(rng.uniform(*rule.yaw)) if rule.yaw is not None else 0.0
            placed[name] = np.array([x, y])
        if _apart(placed, fixed, task.min_distance_m):
            poses = {n: [float(placed[n][0]), float(placed[n][1]), float(scene.object(n).pos[2]), *yaw_quat(yaws[n])]
                     for n in names}
            return EpisodeStart(int(seed), int(episode), s, poses)
    raise ValueError(f"task.start: no draw in {MAX_DRAWS} put the objects {names} {task.min_distance_m} m apart "
                     "from each other and from the scene's other objects; widen the ranges or lower "
                     "task.min_distance_m")


def _apart(placed: dict, fixed: dict, gap: float) -> bool:
    import numpy as np

    items = list(placed.items())
    for i, (_, p) in enumerate(items):
        others = [q for _, q in items[i + 1:]] + list(fixed.values())
        if any(np.linalg.norm(p - q) < gap for q in others):
            return False
    return True
