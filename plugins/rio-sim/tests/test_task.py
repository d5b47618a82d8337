"""Sim tasks: seeded, reproducible starts within the declared ranges; the success predicate on world states
built by hand; the time limit ending a run; a station file's task refused naming the field."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rio_sim.scenes import CUBE, build_model, get_scene
from rio_sim.success import PickPlaceJudge
from rio_sim.task import TaskConfig, episode_seed, sample_start

from rio.errors import ConfigError
from rio.station.edit import with_component
from rio.station.load import load_station


def station_task(station: str) -> TaskConfig:
    return load_station(station).components["world_sensor"].config.task


@pytest.mark.parametrize("station", ["sim-so100", "sim-bimanual"])
def test_starts_are_reproducible_differ_by_seed_and_episode_and_stay_in_their_ranges(station):
    task = station_task(station)
    scene = get_scene(load_station(station).components["world_sensor"].config.scene)
    assert set(task.start) >= {cube for _, cube, _ in scene.pick_place} | {pad for _, _, pad in scene.pick_place}
    first = [sample_start(task, scene, 0, k).poses for k in range(100)]
    assert first == [sample_start(task, scene, 0, k).poses for k in range(100)]  # same seed, same starts
    other = [sample_start(task, scene, 1, k).poses for k in range(100)]
    for a, b in zip(first, other, strict=True):  # another seed: every object elsewhere, every episode
        assert all(np.linalg.norm(np.subtract(a[n][:2], b[n][:2])) > 1e-6 for n in a)
    assert len({episode_seed(0, k) for k in range(100)} | {episode_seed(1, k) for k in range(100)}) == 200
    xy = {n: np.array([p[n][:2] for p in first]) for n in task.start}
    for name, rule in task.start.items():
        lo, hi = np.array([rule.x[0], rule.y[0]]), np.array([rule.x[1], rule.y[1]])
        assert (xy[name] >= lo).all() and (xy[name] <= hi).all(), name
        # spread over the ranges, not stuck in a corner: each coordinate covers most of its range
        assert ((xy[name].max(0) - xy[name].min(0)) > 0.8 * (hi - lo)).all(), name
        z = [p[name][2] for p in first]
        assert np.allclose(z, scene.object(name).pos[2])  # on the table, where the scene rests it
        if rule.yaw is not None:
            yaw = np.array([2 * math.atan2(p[name][6], p[name][3]) for p in first])
            yaw = (yaw + math.pi) % (2 * math.pi) - math.pi
            assert yaw.min() >= rule.yaw[0] - 1e-9 and yaw.max() <= rule.yaw[1] + 1e-9
            assert np.ptp(yaw) > 0.8 * (rule.yaw[1] - rule.yaw[0])
    for poses in first:  # apart from each other by the declared distance
        names = list(poses)
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                assert np.linalg.norm(np.subtract(poses[a][:2], poses[b][:2])) >= task.min_distance_m


def test_a_draw_that_cannot_fit_is_refused_naming_the_field():
    scene = get_scene("so100")
    task = TaskConfig(start={"cube": {"x": [0.2, 0.2], "y": [0.0, 0.0]}, "pad": {"x": [0.2, 0.2], "y": [0.01, 0.01]}})
    with pytest.raises(ValueError, match=r"task.start: no draw in 1000 put the objects \['cube', 'pad'\]"):
        sample_start(task, scene, 0, 0)


@pytest.mark.parametrize(("fields", "message"), [
    ({"start": {"cub": {"x": [0.1, 0.2]}}}, r"task.start.cub: scene 'so100' has no movable object 'cub'"),
    ({"start": {"cube": {"x": [0.3, 0.2]}}}, r"components.world_sensor.task.start.cube.x: .*low <= high"),
    ({"time_limit_s": 0}, r"components.world_sensor.task.time_limit_s"),
    ({"kind": "stack"}, r"components.world_sensor.task.kind: .*unknown task kind 'stack'"),
    ({"seeds": 3}, r"components.world_sensor.task.seeds"),
])
def test_a_bad_task_in_a_station_is_refused_naming_the_field(fields, message):
    with pytest.raises(ConfigError, match=message):
        with_component(load_station("sim-so100"), "world_sensor", fields={"task": fields})


# -- the success predicate, on states built by hand ---------------------------------------------------------
@pytest.fixture(scope="module")
def world():
    """The so100 scene, its judge, and a way to pose it: the cube at (x, y, z), the arm's grasp site there
    (IK) with the fingers open to `width`."""
    import mujoco
    from rio_sim.indices import arm_indices
    from rio_sim.robots import get_robot

    from rio.kinematics import solver_from_description

    scene, model = get_scene("so100"), build_model("so100")
    robot = get_robot("so100")
    idx = arm_indices(model, "arm", robot)
    ik = solver_from_description({"format": "mjcf", "xml": robot.xml(), "frame": "grasp", "frame_type": "site",
                                  "joints": list(robot.arm_joints)}, orientation_cost=0.1, damping=1e-4)
    home_pose = ik.fk(np.asarray(robot.home))

    def pose(cube_xyz, width, tool_xyz=None) -> mujoco.MjData:
        d = mujoco.MjData(model)
        d.qpos[idx.qpos] = robot.home
        if tool_xyz is not None:
            q = np.asarray(robot.home, dtype=float)
            for _ in range(5):
                res = ik.solve(np.concatenate([tool_xyz, home_pose[3:]]), q, max_iters=50)
                q = res.q
            assert res.pos_err < 1e-3
            d.qpos[idx.qpos] = q
        d.qpos[idx.finger_qpos] = width / 2
        j = model.joint("cube")
        d.qpos[j.qposadr[0]:j.qposadr[0] + 7] = [*cube_xyz, 1, 0, 0, 0]
        mujoco.mj_forward(model, d)
        return d

    pad = np.asarray(scene.object("pad").pos)
    return PickPlaceJudge(model, scene), pose, pad


def test_success_is_the_cube_resting_on_the_pad_released(world):
    judge, pose, pad = world
    rest = CUBE / 2
    assert judge(pose([pad[0], pad[1], rest], 0.06))                   # on the pad, the arm away at home
    assert judge(pose([pad[0] + 0.025, pad[1] - 0.025, rest], 0.06))   # near its corner, still over it
    assert not judge(pose([pad[0] + 0.04, pad[1], rest], 0.06))        # off the pad
    assert not judge(pose([pad[0], pad[1] + 0.12, rest], 0.06))        # where it started: far off
    assert not judge(pose([pad[0], pad[1], rest + 0.03], 0.06))        # above the pad, not resting on it


def test_a_cube_still_in_the_fingers_is_not_released(world):
    judge, pose, pad = world
    cube = [pad[0], pad[1], CUBE / 2]
    grasped = pose(cube, CUBE - 0.002, tool_xyz=cube)     # fingers squeezing it, over the pad
    assert not judge(grasped)
    assert judge.held(grasped, judge.pairs[0])
    released = pose(cube, 0.06, tool_xyz=cube)            # the same, fingers open
    assert judge(released)


def test_bimanual_success_needs_both_cubes(world):
    import mujoco

    scene, model = get_scene("so100_bimanual"), build_model("so100_bimanual")
    judge = PickPlaceJudge(model, scene)
    d = mujoco.MjData(model)
    mujoco.mj_forward(model, d)
    assert judge.placed(d) == [False, False]

    def put(cube: str, pad: str) -> None:
        j, p = model.joint(cube), scene.object(pad).pos
        d.qpos[j.qposadr[0]:j.qposadr[0] + 7] = [p[0], p[1], CUBE / 2, 1, 0, 0, 0]
        mujoco.mj_forward(model, d)

    put("cube_left", "pad_left")
    assert judge.placed(d) == [True, False] and not judge(d)
    put("cube_right", "pad_right")
    assert judge(d)


# -- the objects a world reports ---------------------------------------------------------------------------
def test_a_world_reports_the_objects_it_is_given_in_their_order():
    """The learning loop's station reports the task's cube and pad only: the can's and block's poses, which
    nothing moves, came out at up to 7 standard deviations of their training data in evaluations (noise for
    a state-based policy)."""
    from rio_sim.world import SimWorld

    every = [o.name for o in get_scene("so100").free_objects]
    assert SimWorld(scene="so100").object_names() == every and {"can", "block"} <= set(every)
    world = SimWorld(scene="so100", objects=["pad", "cube"])
    assert world.object_names() == ["pad", "cube"] and world.example_data["object_poses"].shape == (2, 7)
    assert load_station("sim-so100-loop").components["world_sensor"].config.objects == ["cube", "pad"]


@pytest.mark.parametrize(("objects", "message"), [
    (["cub"], r"scene 'so100' does not move \['cub'\]"),
    ([], r"name at least one"),
    (["cube", "cube"], r"each once"),
])
def test_objects_a_scene_does_not_move_are_refused_naming_the_field(objects, message):
    with pytest.raises(ConfigError, match=rf"components.world_sensor.objects: .*{message} \(the scene's free "
                                          r"objects: cube, pad, can, block\)"):
        with_component(load_station("sim-so100"), "world_sensor", fields={"objects": objects})
