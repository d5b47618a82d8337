"""Test helpers for code driving rio-sim worlds: a running world for code that attaches to one from
outside a station (emulators, `WorldArm` users), and the one check that a scripted pick-and-place on a
sim station did the task, from the world's ground truth."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


@contextmanager
def running_world(scene: str = "xarm7", world: str = "sim") -> Iterator[Any]:
    """Serve a `sim.world` of `scene` named `world` (thread middleware) until the block ends; yields its
    client (`get_state()`, `object_names()`, ...)."""
    from rio.runtime.manager import ServerManager
    from rio.station import make_station, parse_station

    station = parse_station({"name": f"world-{world}", "rate_hz": 30, "middleware": {"name": "thread"},
                             "components": {"world_sensor": {"driver": "sim.world", "scene": scene, "world": world}}})
    servers, clients, _ = make_station(station)
    with ServerManager(servers), clients["world_sensor"]() as client:
        yield client


def without_task(station: Any) -> Any:
    """Sim `station` (name, path or `Station`) with its world's task taken out: the objects stay where the
    scene puts them, where the packaged script (`teleop.scripted`, preset pick_place) picks and places."""
    from rio.station.edit import with_component
    from rio.station.load import load_station

    return with_component(load_station(station), "world_sensor", fields={"task": None})


def check_cube_on_pad(summary: Any, robot: str, tolerance_m: float = 0.015) -> None:
    """The world's cube (scene object "cube") was lifted, carried to the pad of `robot`'s scene and put
    down on the table, according to a teleop run's `summary` (its objects are the world's ground truth)."""
    import numpy as np

    from .robots import get_robot
    from .scenes import CUBE, PLACE_OFFSET

    assert summary.reason == "the device finished", summary.format()
    cube = next(o for o in summary.objects if o.name == "cube")
    pad = np.asarray(get_robot(robot).home_tool) + PLACE_OFFSET
    assert np.linalg.norm(cube.end[:2] - pad[:2]) < tolerance_m, summary.format()  # on the pad ...
    assert cube.max_z > cube.start[2] + 0.04, summary.format()  # ... lifted on the way ...
    assert abs(cube.end[2] - CUBE / 2) < 0.004, summary.format()  # ... and put down on the table


def record_pick_and_place(station: str, root: Any, duration: float = 30.0, cli: bool = False) -> Any:
    """Record one scripted pick-and-place on sim `station` into dataset `root`, by the code of
    `rio teleop STATION --teleop scripted --record ROOT` (thread middleware), or (`cli`) by that command
    in a process of its own with the station's middleware. Returns `root`."""
    instruction = "put the red cube on the blue pad"
    if cli:
        from rio.testing import run_rio

        out = run_rio("teleop", station, "--teleop", "scripted", "--duration", f"{duration:g}", "--record",
                      str(root), "--on-end", "keep", "--instruction", instruction)
        assert "1 episode(s) kept" in out.stdout, out.stdout[-2000:]
        return root
    from rio.cli.teleop_cmd import teleop

    teleop(station, device="scripted", instruction=instruction, duration=duration, middleware="thread",
           record=str(root), on_end="keep")
    return root


def cube_path(root: Any) -> Any:
    """The cube's position at every step of episode 0 of dataset `root`, from the world's ground truth
    (the world sensor's object 0 is the cube)."""
    from rio.recording.dataset import Dataset

    return Dataset(root).episode(0).column("meta.sensors.world.object_poses")[:, 0, :3]


def check_recorded_pick_and_place(root: Any, robot: str | None = None, tolerance_m: float = 0.015) -> Any:
    """Episode 0 of `root` holds the cameras and enough steps, verifies, and its ground truth shows the
    cube carried over to the pad (12 cm away; with `robot`, within `tolerance_m` of its scene's pad),
    lifted on the way and put down. Returns the episode."""
    import numpy as np

    from rio.recording.dataset import Dataset

    from .robots import get_robot
    from .scenes import PLACE_OFFSET

    ep = Dataset(root).episode(0)
    assert set(ep.cameras) >= {"front", "wrist"}, ep.cameras
    assert len(ep.column("t")) > 10 * ep.fps
    cube = cube_path(root)
    assert np.linalg.norm(cube[-1, :2] - cube[0, :2]) > 0.10, cube[[0, -1]]
    assert cube[:, 2].max() > cube[0, 2] + 0.04, cube[:, 2].max()
    assert abs(cube[-1, 2] - cube[0, 2]) < 0.005, cube[[0, -1]]
    if robot is not None:
        pad = np.asarray(get_robot(robot).home_tool) + PLACE_OFFSET
        assert np.linalg.norm(cube[-1, :2] - pad[:2]) < tolerance_m, (cube[-1], pad)
    assert not ep.verify()
    return ep


def check_replay_repeats_the_task(station: str, root: Any, rollout: Any, duration: float = 20.0,
                                  cli: bool = False) -> None:
    """`rio deploy STATION --policy replay.episode,episode=ROOT --record ROLLOUT` (its code, thread
    middleware; or `cli`: the command in a process of its own) carries the cube again and puts it down
    within 2 cm of where the recording did."""
    import numpy as np

    policy = f"replay.episode,episode={root}"
    if cli:
        from rio.testing import run_rio

        said = run_rio("deploy", station, "--policy", policy, "--duration", f"{duration:g}", "--record",
                       str(rollout)).stdout[-2000:]
    else:
        from rio.workflows.deploy import run_deploy

        said = run_deploy(station, policy, record=str(rollout), duration=duration, middleware="thread",
                          log=None).format()
    taught, replayed = cube_path(root), cube_path(rollout)
    assert np.linalg.norm(replayed[-1, :2] - replayed[0, :2]) > 0.10, said
    assert np.linalg.norm(replayed[-1, :2] - taught[-1, :2]) < 0.02, said


def check_humanoid_replay(root: Any, station: str, body_dof: int) -> None:
    """Episode 0 of `root` (a humanoid teleop recording on sim `station`) replays (`rio replay`'s code,
    thread middleware) to the same joint trajectory: every joint's median error under 0.02 rad, to within
    a control period of timing; the body's `body_dof` joints (first in the proprio) never more than 0.1 rad
    off. The hands' joints, after them, may jump as the tracker acquires the hands (~1 rad at the hand
    node's step limit per cycle: as fast as that node runs, which a loaded machine slows)."""
    import numpy as np

    from rio.recording.dataset import Dataset
    from rio.workflows.replay import replay_episode

    ep = Dataset(root).episode(0)
    t_rec = ep.column("t") - ep.column("t")[0]
    q_rec = ep.column("obs.proprio")
    seen: list = []
    replay_episode(root, 0, station, middleware="thread", approach_s=0.3, log=None, on_tick=lambda tick: seen.append(
        (tick.step.meta["t_obs"], np.asarray(tick.step.observation.proprio))))
    t_rep = np.array([s[0] for s in seen]) - seen[0][0]
    q_rep = np.stack([s[1] for s in seen])
    mid = (t_rep > 0.3) & (t_rep < t_rec[-1] - 0.3)
    shifts = np.array([-1.0, 0.0, 1.0])[:, None] / ep.fps
    for j in range(q_rec.shape[1]):
        err = np.abs(q_rep[mid, j] - np.interp(t_rep[mid] + shifts, t_rec, q_rec[:, j])).min(axis=0)
        assert np.median(err) < 0.02, (j, float(np.median(err)))
        assert j >= body_dof or err.max() < 0.1, (j, float(err.max()))
    np.testing.assert_allclose(q_rep[-1], q_rec[-1], atol=0.03)
