"""Driver contract v2: one config convention, the API derived from markers, presets, and the safety and
kinematics every arm gets from its kind (not from its driver)."""

from __future__ import annotations

import time
import types

import numpy as np
import pytest

from rio import ServerManager, connect, remote, serve
from rio.control import pose_error
from rio.errors import ConfigError, InvalidRequest
from rio.fakes.arms import FakeArm, FakeGripper, FakeModelArm
from rio.interfaces import ArmNode
from rio.plugins import Registry
from rio.plugins.hookspecs import hookimpl
from rio.plugins.specs import Spec
from rio.runtime.node import Node
from rio.station import parse_station
from rio.testing import lifecycle, wait_until


def run_for(node, seconds: float, period: float = 0.005):
    """Tick a node's loop in this thread (what the runtime does), return the last sample."""
    t_end = time.monotonic() + seconds
    s = node.cycle()
    while time.monotonic() < t_end:
        time.sleep(period)
        s = node.cycle()
    return s


# -- config convention --------------------------------------------------------------------------------
def test_a_component_receives_its_validated_config_from_fields_or_an_object():
    a = FakeArm(dof=3, rate_hz=50)
    assert isinstance(a.config, FakeArm.Config) and a.config.dof == 3 and a.rate_hz == 50
    b = FakeArm(FakeArm.Config(dof=4), rate_hz=20)  # an object, with fields on top
    assert (b.dof, b.rate_hz) == (4, 20)
    with pytest.raises(ValueError, match="dof"):
        FakeArm(dof=0)


def registry_with(hook: str, *specs: Spec) -> Registry:
    """The core's plugin plus one inline plugin whose `hook` returns `specs`."""
    reg = Registry(load_entry_points=False)
    mod = types.ModuleType(f"inline_{hook}")
    setattr(mod, hook, hookimpl(specname=hook)(lambda: list(specs)))
    reg.register(mod, name=f"inline-{hook}")
    return reg


def test_station_fields_over_a_preset_and_a_contradicting_one_is_an_error():
    reg = registry_with("rio_drivers", Spec("acme.arm7", "arm", "rio.fakes.arms:FakeArm", "7-joint variant",
                                            preset={"dof": 7}))
    st = parse_station({"name": "p", "components": {"arm": {"driver": "acme.arm7"}}}, registry=reg)
    assert st.components["arm"].config.dof == 7
    with pytest.raises(ConfigError, match=r"components\.arm\.dof: 'acme.arm7' fixes it to 7 \(got 6\)"):
        parse_station({"name": "p", "components": {"arm": {"driver": "acme.arm7", "dof": 6}}}, registry=reg)


def test_api_is_derived_from_markers_and_overrides_keep_them():
    assert {"robot_description", "enable", "disable", "home", "hold", "joint_limits", "move_joints",
            "move_eef", "joint_names", "get_state", "send_request"} <= set(FakeModelArm.__api__)
    assert "robot_description" in FakeModelArm.remote_methods()  # overridden without a decorator
    assert "move_joints" not in FakeModelArm.remote_methods()  # client-side
    assert "read_joints" not in FakeModelArm.__api__

    with pytest.raises(TypeError, match="lists __api__ by hand"):
        type("Old", (Node,), {"__api__": ("get_state",)})

    class Pinger(Node):
        def setup(self):
            self.example_data = {"x": 0.0}

        def read_state(self):
            return {"x": 1.0}

        @remote
        def ping(self) -> str:
            return "pong"

    assert Pinger.remote_methods() == {"ping"}


# -- safety owned by the kind -------------------------------------------------------------------------
def test_joint_targets_are_clipped_step_limited_and_refused_when_disabled():
    arm = FakeArm(dof=2, max_step_rad=0.01, joint_limits=[(-0.5, 0.5), (-0.1, 0.1)])
    with lifecycle(arm):
        assert arm.enabled and arm.joint_limits() == [[-0.5, -0.1], [0.5, 0.1]]
        arm.command_joints(np.array([3.0, -3.0]), time.monotonic())
        s = arm.cycle()
        assert np.allclose(s["joint_pos"], [0.0, 0.0])  # read before the first write of this cycle
        s = arm.cycle()
        assert np.allclose(s["joint_pos"], [0.01, -0.01])  # one bounded step, never the jump
        s = run_for(arm, 0.4)
        assert np.allclose(s["joint_pos"], [0.5, -0.1])  # ends clipped at the limits
        arm.disable()
        with pytest.raises(InvalidRequest, match="disabled"):
            arm.command_joints(np.zeros(2), time.monotonic())
        assert not arm.cycle()["enabled"]
        arm.enable()
        arm.home(0.05)
        assert np.allclose(run_for(arm, 0.5)["joint_pos"], 0.0)


def test_a_silent_stream_is_held_by_the_watchdog():
    arm = FakeArm(dof=1, max_step_rad=10.0, watchdog_s=0.1)
    with lifecycle(arm):
        t = time.monotonic()
        arm.command_joints(np.array([0.0]), t)
        arm.command_joints(np.array([1.0]), t + 2.0)  # a stream's far target, then silence
        s = run_for(arm, 0.4)
        assert s["holding"] and 0.0 < s["joint_pos"][0] < 0.2
        held = s["joint_pos"][0]
        assert run_for(arm, 0.2)["joint_pos"][0] == pytest.approx(held)


def test_gripper_targets_are_clipped_to_its_width():
    g = FakeGripper(max_width=0.08, max_step_m=0.05)
    with lifecycle(g):
        g.handle_request({"width": 0.5, "t_cmd_target": time.monotonic(), "force": 0.0})
        assert run_for(g, 0.1)["width"] == pytest.approx(0.08)
        g.handle_request({"width": -1.0, "t_cmd_target": time.monotonic(), "force": 0.0})
        assert run_for(g, 0.1)["width"] == pytest.approx(0.0)


def test_a_gripper_request_still_takes_its_old_key_with_one_notice(caplog, monkeypatch):
    """Before Core v3 the opening was `position`: a script sending it moves the gripper as `width` does,
    with one line saying so; both at once is an error naming both."""
    import rio.config

    monkeypatch.setattr(rio.config, "_noticed", set())
    with ServerManager("thread", [serve(FakeGripper, name="gripper", max_width=0.08)]):
        with connect(FakeGripper, "thread", name="gripper") as g, caplog.at_level("WARNING", logger="rio.config"):
            g.move(0.03)
            assert wait_until(lambda: g.get_state()["width"] == pytest.approx(0.03))
            for _ in range(2):
                g.send_request(position=0.01, t_cmd_target=time.monotonic(), force=0.0)
            assert wait_until(lambda: g.get_state()["width"] == pytest.approx(0.01))
            with pytest.raises(ValueError, match="position and width are one field"):
                g.send_request(position=0.02, width=0.02, t_cmd_target=time.monotonic(), force=0.0)
    assert [r.getMessage() for r in caplog.records] == [
        "GripperRequest: 'position' is now 'width' (the old name is accepted until the next release)"]


# -- kinematics from robot_description() -------------------------------------------------------------
def test_arm_without_cartesian_control_gets_fk_and_ik_from_its_model():
    pytest.importorskip("mink")
    from rio.kinematics import solver_from_description

    arm = FakeModelArm()
    with lifecycle(arm):
        arm.home(0.05)
        s = run_for(arm, 0.3)
        fk = solver_from_description(arm.robot_description()).fk(s["joint_pos"])
        assert np.isfinite(s["eef_pose"]).all() and sum(pose_error(fk, s["eef_pose"])) < 1e-9
        target = s["eef_pose"].copy()
        target[:3] += [0.03, -0.02, -0.04]
        arm.command_eef(target, time.monotonic() + 0.2)
        s = run_for(arm, 0.6)
        pe, re = pose_error(s["eef_pose"], target)
        assert pe < 0.003 and re < np.deg2rad(2)


def test_arm_without_model_or_cartesian_control_refuses_eef_targets():
    class JointsOnly(FakeModelArm):
        def robot_description(self):
            return None

    arm = JointsOnly()
    with lifecycle(arm):
        s = arm.cycle()
        assert np.isnan(s["eef_pose"]).all()  # unmeasured: NaN, never a made-up pose
        with pytest.raises(InvalidRequest, match="no Cartesian control and no robot_description"):
            arm.command_eef(np.array([0.3, 0, 0.2, 1, 0, 0, 0]), time.monotonic())


def test_description_joints_must_match_the_driver():
    class Mismatch(FakeModelArm):
        def robot_description(self):
            return {**super().robot_description(), "joints": ["a", "b"]}

    arm = Mismatch()
    arm.open()
    with pytest.raises(ValueError, match="differ from the node's joint_names"):
        arm.opened()


def test_end_effector_teleop_works_on_an_arm_that_only_ships_a_model():
    """The teleop bindings start from the published eef_pose: an arm that reports joints only is now
    teleoperable because its kind computes forward kinematics."""
    pytest.importorskip("mink")
    from rio.station import make_station
    from rio.teleop.bindings import bind_arms, build_action

    st = parse_station({"name": "fk", "rate_hz": 50, "middleware": {"name": "thread"},
                        "components": {"arm": {"driver": "rio.fake_model_arm"}}})
    servers, _clients, env = make_station(st)
    with ServerManager(servers), env:
        env.robot.arm.home(0.05)
        assert wait_until(lambda: env.robot.arm.get_state()["joint_pos"][2] > 1.1)
        env.reset()
        (b,) = bind_arms(env.robot)
        b.reset_target()
        start = b.target.copy()
        b.target[:3] += [0.0, 0.0, 0.03]
        for _ in range(20):
            env.step(build_action(env.robot, [b]))
        assert wait_until(lambda: env.robot.arm.get_state()["eef_pose"][2] > start[2] + 0.025, timeout=3.0)


def test_contract_runs_the_same_over_a_process_middleware():
    with ServerManager("shm", [serve(FakeModelArm, name="arm")]):
        with connect(FakeModelArm, "shm", name="arm") as arm:
            assert arm.num_joints() == 6 and arm.joint_names()[0] == "j1"
            assert arm.robot_description()["format"] == "mjcf"
            arm.move_joints(np.full(6, 0.2), time.monotonic() + 0.1)
            assert wait_until(lambda: np.allclose(arm.get_state()["joint_pos"], 0.2))
            arm.disable()
            assert wait_until(lambda: not arm.get_state()["enabled"])


def test_kinds_are_abstract_about_hardware_only():
    """A driver that forgets its hardware hooks fails by name at the first use, not silently."""

    class Lazy(ArmNode):
        def default_joint_names(self):
            return ["a"]

    with pytest.raises(NotImplementedError, match="Lazy must define read_joints"):
        Lazy().opened()


def test_a_registered_policy_variant_is_a_preset():
    from rio.policy.resolve import resolve_policy

    reg = registry_with("rio_policies", Spec("acme.fast", "policy", "rio.policy.testing:RampPolicyNode", "steep ramp",
                                             preset={"slope": 4.0}))
    station = types.SimpleNamespace(name="s", components={})
    name, cls, kwargs = resolve_policy("acme.fast,chunk=8", station, reg)
    assert (name, kwargs["slope"], kwargs["chunk"]) == ("acme.fast", 4.0, 8)
    with pytest.raises(ConfigError, match=r"--policy\.slope: 'acme.fast' fixes it to 4.0 \(got 1\)"):
        resolve_policy("acme.fast,slope=1", station, reg)
