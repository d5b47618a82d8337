"""Embodiments inferred from roles, and make_station + Env stepping fake devices on the thread middleware."""

from __future__ import annotations

import sys
import types

import numpy as np
import pytest

from rio import ServerManager, clock
from rio.embodiments.infer import infer_embodiment
from rio.errors import ConfigError, RioError
from rio.plugins import Registry
from rio.plugins.hookspecs import hookimpl
from rio.plugins.specs import Spec
from rio.schema import BimanualObs, HumanoidObs, Observation, SingleArmObs, Step
from rio.station import make_station, parse_station
from rio.testing import wait_until


@pytest.fixture
def reg():
    return Registry(load_entry_points=False)


def station(reg, components, **top):
    return parse_station({"name": "emb-test", "middleware": {"name": "thread"}, "rate_hz": 50,
                          "components": components, **top}, registry=reg)



@pytest.mark.parametrize("roles, expected", [
    ({"arm"}, "single_arm"),
    ({"arm", "gripper", "front_camera", "teleop"}, "single_arm"),
    ({"arm", "arm2", "gripper", "gripper2"}, "bimanual"),
    ({"humanoid", "hand", "hand2"}, "humanoid"),
    ({"teleop", "front_camera"}, None),
])
def test_embodiment_inferred_from_roles(reg, roles, expected):
    spec = infer_embodiment(roles, registry=reg)
    assert (spec.name if spec else None) == expected


def test_named_embodiment_must_fit_the_roles(reg):
    assert infer_embodiment({"arm", "arm2"}, "single_arm", registry=reg).name == "single_arm"
    with pytest.raises(ConfigError, match=r"'bimanual' needs roles \['arm', 'arm2'\]"):
        infer_embodiment({"arm"}, "bimanual", registry=reg)
    with pytest.raises(ConfigError, match=r"unknown embodiment 'bimanul'; did you mean 'bimanual'\?"):
        infer_embodiment({"arm"}, "bimanul", registry=reg)


class ArmWithWristCamera:
    """A plugin embodiment more specific than SingleArm (only its required roles matter here)."""

    required_roles = frozenset({"arm", "wrist_camera"})


def test_plugin_embodiment_wins_when_more_specific_and_ties_are_errors(reg, monkeypatch):
    targets = types.ModuleType("emb_targets")  # where the specs' import paths point
    targets.ArmWithWristCamera = ArmWithWristCamera
    monkeypatch.setitem(sys.modules, "emb_targets", targets)
    mod = types.ModuleType("emb_plugin")

    @hookimpl
    def rio_embodiments():
        return [Spec("arm_wrist", "embodiment", "emb_targets:ArmWithWristCamera")]

    mod.rio_embodiments = rio_embodiments
    reg.register(mod, name="emb-plugin")
    assert infer_embodiment({"arm", "wrist_camera"}, registry=reg).name == "arm_wrist"
    assert infer_embodiment({"arm", "front_camera"}, registry=reg).name == "single_arm"

    tie = types.ModuleType("tie_plugin")

    @hookimpl
    def rio_embodiments():  # noqa: F811 - a second plugin's hook
        return [Spec("arm_wrist_too", "embodiment", "emb_targets:ArmWithWristCamera")]

    tie.rio_embodiments = rio_embodiments
    reg.register(tie, name="tie-plugin")
    with pytest.raises(ConfigError, match=r"fit several embodiments equally: \['arm_wrist', 'arm_wrist_too'\]"):
        infer_embodiment({"arm", "wrist_camera"}, registry=reg)


def test_schema_morphologies_extend_observation():
    for cls in (SingleArmObs, BimanualObs, HumanoidObs):
        obs = cls(proprio=np.zeros(3))
        assert isinstance(obs, Observation) and obs.cameras == {}
    step = Step(timestep=0, observation=Observation(np.zeros(1)), instruction=None, action=None)
    assert step.meta == {}


def test_single_arm_station_steps(reg):
    st = station(reg, {
        "arm": {"driver": "rio.fake_arm", "dof": 6},
        "gripper": {"driver": "rio.fake_gripper", "max_width": 0.08},
        "front_camera": {"driver": "rio.fake_camera", "depth": True, "width": 32, "height": 24},
        "teleop": {"driver": "rio.fake_teleop", "twist": [0.1, 0, 0, 0, 0, 0]},
    })
    servers, clients, env = make_station(st, registry=reg)
    assert set(servers) == set(clients) == {"arm", "gripper", "front_camera", "teleop"}
    assert servers["arm"].name == "arm"
    with pytest.raises(RioError, match="use it as `with env:`"):
        env.get_state()
    with ServerManager(servers):
        with env, clients["teleop"]() as teleop:
            assert np.allclose(teleop.get_state()["twist"], [0.1, 0, 0, 0, 0, 0])
            assert env.robot.describe_action() == "joint_pos (6), gripper (1)"
            first = env.reset()
            assert first.timestep == 0 and first.action is None
            obs = first.observation
            assert isinstance(obs, SingleArmObs)
            assert np.allclose(obs.proprio, [0, 0, 0, 0, 0, 0, 0.08])
            cam = obs.cameras["front"]
            assert cam.rgb.shape == (24, 32, 3) and cam.rgb.dtype == np.uint8
            assert cam.depth.dtype == np.float32 and np.allclose(cam.depth, 1.0)  # meters
            assert cam.meta["intrinsics"].shape == (3, 3)

            env.instruction = "pick up the cube"
            target = np.r_[np.linspace(-0.5, 0.5, 6), 0.02]
            step = env.step(target, t_cmd_target=clock.now() + 0.1)
            assert step.timestep == 1 and np.array_equal(step.action, target)
            assert step.instruction == "pick up the cube"
            assert set(step.meta["timestamps"]) == {"arm", "gripper", "front_camera"}
            assert wait_until(lambda: np.allclose(env.get_state().observation.proprio, target, atol=1e-6))
            final = env.get_state().observation
            assert final.gripper_width == pytest.approx(0.02)
            assert np.allclose(final.proprio_joints, target[:6])

            with pytest.raises(ValueError, match=r"action has 6 values, expected 7: joint_pos \(6\), gripper \(1\)"):
                env.step(np.zeros(6))
            with pytest.raises(ValueError, match="NaN"):
                env.step(np.r_[np.zeros(6), np.nan])
            assert env.timestep == 1


def test_single_arm_eef_action_space(reg):
    st = station(reg, {"arm": {"driver": "rio.fake_arm"}}, embodiment={"action_space": "eef_pose"})
    servers, _, env = make_station(st, registry=reg)
    with ServerManager(servers), env:
        assert env.action_dim == 7
        pose = np.array([0.3, 0.0, 0.2, 0.0, 1.0, 0.0, 0.0])
        env.step(pose, t_cmd_target=clock.now() + 0.05)
        assert wait_until(lambda: np.allclose(env.get_state().observation.proprio_eef, pose))
        assert np.allclose(env.get_state().observation.proprio, pose)


def test_bimanual_station_steps(reg):
    st = station(reg, {
        "arm": {"driver": "rio.fake_arm", "dof": 6}, "gripper": {"driver": "rio.fake_gripper"},
        "arm2": {"driver": "rio.fake_arm", "dof": 6}, "gripper2": {"driver": "rio.fake_gripper"},
    })
    servers, _, env = make_station(st, registry=reg)
    with ServerManager(servers), env:
        assert env.action_dim == 14
        assert env.robot.describe_action().startswith("arm1_joint_pos (6), arm1_gripper (1), arm2_joint_pos (6)")
        # every action element named from the drivers (what exports carry as `names`), the arms told apart
        names = env.robot.action_names()
        assert names[:7] == [f"arm1_joint{i}" for i in range(1, 7)] + ["arm1_gripper"]
        assert names[7:] == [f"arm2_joint{i}" for i in range(1, 7)] + ["arm2_gripper"]
        assert env.robot.observation_names()["arm2_proprio_joints"] == names[7:13]
        assert env.drivers["arm2"] == "rio.fake_arm"
        left, right = np.full(6, 0.3), np.full(6, -0.3)
        action = env.robot.build_action(arm1_joint_pos=left, arm1_gripper=0.01, arm2_joint_pos=right,
                                        arm2_gripper=0.05)
        env.step(action, t_cmd_target=clock.now() + 0.05)
        assert wait_until(lambda: np.allclose(env.get_state().observation.proprio, action))
        obs = env.get_state().observation
        assert isinstance(obs, BimanualObs)
        assert np.allclose(obs.arm1_proprio_joints, left) and np.allclose(obs.arm2_proprio_joints, right)
        assert (obs.gripper1_width, obs.gripper2_width) == (pytest.approx(0.01), pytest.approx(0.05))


def test_humanoid_station_steps(reg):
    st = station(reg, {"humanoid": {"driver": "rio.fake_humanoid", "dof": 12},
                       "hand": {"driver": "rio.fake_hand", "dof": 6}})
    servers, _, env = make_station(st, registry=reg)
    with ServerManager(servers), env:
        assert env.robot.describe_action() == "joint_pos (12), hand (6)"
        names = env.robot.action_names()
        assert names == [f"joint{i}" for i in range(1, 13)] + [f"hand.joint{i}" for i in range(1, 7)]
        assert env.robot.observation_names()["hand1_joints"] == names[12:]
        action = np.r_[np.full(12, 0.1), np.full(6, 0.4)]
        env.step(action, t_cmd_target=clock.now() + 0.05)
        assert wait_until(lambda: np.allclose(env.get_state().observation.proprio, action))
        obs = env.get_state().observation
        assert isinstance(obs, HumanoidObs)
        assert np.allclose(obs.base_quat, [1, 0, 0, 0]) and obs.hand2_joints is None
        assert np.allclose(obs.hand1_joints, 0.4)


def test_station_without_embodiment_has_no_env(reg):
    st = station(reg, {"teleop": {"driver": "rio.fake_teleop"}})
    servers, clients, env = make_station(st, registry=reg)
    assert env is None
    with ServerManager(servers), clients["teleop"]() as teleop:
        assert teleop.get_state()["buttons"].shape == (2,)


def test_station_over_a_process_middleware(reg):
    """The same station with a node per process (shm): configs and classes cross the spawn boundary."""
    pytest.importorskip("rio.middleware.shm")
    st = station(reg, {"arm": {"driver": "rio.fake_arm", "dof": 4},
                       "top_camera": {"driver": "rio.fake_camera", "width": 16, "height": 8}})
    servers, _, env = make_station(st, middleware="shm", registry=reg)
    with ServerManager(servers), env:
        target = np.array([0.1, -0.2, 0.3, -0.4])
        env.step(target, t_cmd_target=clock.now() + 0.05)
        assert wait_until(lambda: np.allclose(env.get_state().observation.proprio, target), timeout=10)
        assert env.get_state().observation.cameras["top"].rgb.shape == (8, 16, 3)


def test_sensor_roles_ride_along_in_step_meta_and_are_recorded(tmp_path):
    """A `<name>_sensor` belongs to no morphology: each step carries its latest sample in
    meta["sensors"], which the recorder stores as columns."""
    from rio.recording import Dataset, Recorder
    from rio.station import make_station, parse_station

    st = parse_station({"name": "ft", "middleware": {"name": "thread"}, "components": {
        "arm": {"driver": "rio.fake_arm"}, "ft_sensor": {"driver": "rio.fake_sensor", "value": [1, 2, 3, 0, 0, 0]}}})
    servers, _clients, env = make_station(st)
    with ServerManager(servers), env:
        step = env.reset()
        assert np.allclose(step.meta["sensors"]["ft"]["value"], [1, 2, 3, 0, 0, 0])
        assert "ft_sensor" in step.meta["timestamps"]
        with Recorder(tmp_path / "data", env=env) as rec:
            rec.start_episode()
            for _ in range(5):
                rec.add(env.step(np.zeros(env.action_dim)))
            rec.keep()
    ep = Dataset(tmp_path / "data").episode(0)
    assert np.allclose(ep.column("meta.sensors.ft.value"), [1, 2, 3, 0, 0, 0])


@pytest.mark.parametrize("mw", ["thread", "shm"])
def test_observation_pixels_stay_in_the_camera_ring_until_read(reg, mw):
    """A step's camera frames are complete in meta at once; the pixels are copied out of the camera's ring
    (exactly that frame) only when read, and a frame read after the camera came round to its slot is an
    error naming the camera, never another frame. Pickling (a recorder process) takes the pixels."""
    import pickle

    from rio.errors import FrameGone
    from rio.schema import Camera, RingCamera

    st = station(reg, {"arm": {"driver": "rio.fake_arm", "dof": 4},
                       "top_camera": {"driver": "rio.fake_camera", "width": 16, "height": 8, "depth": True,
                                      "rate_hz": 200.0}})
    servers, clients, env = make_station(st, middleware=mw, registry=reg)
    with ServerManager(servers), env:
        cam = env.get_state().observation.cameras["top"]
        assert isinstance(cam, RingCamera) and not cam.taken
        ts = cam.meta["timestamp"]
        assert cam.meta["intrinsics"].shape == (3, 3) and not cam.taken
        with clients["top_camera"]() as direct:
            sample = direct.get_state()
            assert wait_until(lambda: direct.get_state()["timestamp"] > ts, timeout=10)  # a newer frame is out
        rgb = cam.rgb
        assert cam.taken and rgb.shape == (8, 16, 3) and cam.depth.dtype == np.float32
        if sample["timestamp"] == ts:
            np.testing.assert_array_equal(rgb, sample["rgb"])
        again = pickle.loads(pickle.dumps(cam))
        assert type(again) is Camera and np.array_equal(again.rgb, rgb) and again.meta["timestamp"] == ts

        late = env.get_state().observation.cameras["top"]
        late_ts = late.meta["timestamp"]
        with clients["top_camera"]() as direct:  # the ring keeps 63 frames: wait for 64 newer ones
            n0 = direct.published()
            assert wait_until(lambda: direct.published() >= n0 + 64, timeout=30)
        for _ in range(2):  # and again: a frame gone never reads as "no image"
            with pytest.raises(FrameGone, match=rf"camera 'top_camera': frame {late_ts:.6f} is no longer"):
                _ = late.rgb


def test_a_node_behind_on_its_link_skips_a_command_and_the_others_still_get_theirs(reg):
    """A network client with every request credit in flight raises NoCredits (nothing sent) at once. The
    embodiment skips that node's command for this cycle and counts it; the gripper's command still goes out,
    and the control loop's summary says how many were skipped. (The arm's client is wrapped by a test double
    that answers NoCredits, as a zmq/zenoh/portal client does when its node is 8 requests behind.)"""
    from rio.errors import NoCredits
    from rio.loop.control_loop import ControlLoop

    class Behind:
        def __init__(self, client):
            self.client = client

        def __getattr__(self, name):
            return getattr(self.client, name)

        def move_joints(self, *_args):
            raise NoCredits("arm", 8, 0.05)

    st = station(reg, {"arm": {"driver": "rio.fake_arm", "dof": 6},
                       "gripper": {"driver": "rio.fake_gripper", "max_width": 0.08}})
    servers, _clients, env = make_station(st, registry=reg)
    with ServerManager(servers), env:
        env.reset()
        env.robot.clients["arm"] = Behind(env.robot.clients["arm"])
        target = np.r_[np.full(6, 0.3), 0.02]
        env.step(target)
        env.step(target)
        assert env.robot.behind == {"arm": 2}
        assert wait_until(lambda: env.get_state().observation.gripper_width == pytest.approx(0.02))
        assert np.allclose(env.get_state().observation.proprio_joints, 0.0)  # the arm got nothing

        class Hold:
            name = "hold"

            def reset(self, loop):
                pass

            def step(self, tick):
                return target

            def done(self):
                return None

        s = ControlLoop(env, Hold(), rate_hz=50.0, duration=0.2, settle=False, log=None).run()
    assert any(w.startswith("arm: ") and "not sent" in w for w in s.warnings), s.warnings
