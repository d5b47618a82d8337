"""`ModelTable`: a vendor arm's joints, home, limits and robot description come from its plugin's model
table, picked by the station's `model`; the station's own fields still narrow them; the table's defaults and
rate bound are the config's, with the kind's descriptions."""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np
import pytest
from pydantic import ValidationError

from rio.fakes.arms import SIX_DOF_MJCF
from rio.interfaces import ArmNode, ModelTable
from rio.testing import lifecycle


@dataclass(frozen=True)
class Entry:
    name: str
    joint_names: tuple[str, ...]
    home: tuple[float, ...]
    limits: tuple[tuple[float, float], ...]


TABLE = {"small": Entry("small", tuple(f"j{i}" for i in range(1, 7)), (0.0, 0.3, 0.6, 0.0, 0.5, 0.0),
                        ((-3.0, 3.0), (-2.0, 2.0), (-2.5, 2.5), (-3.0, 3.0), (-2.0, 2.0), (-3.0, 3.0)))}
described: list[tuple] = []


def describe(name: str, tcp_offset) -> dict:
    described.append((name, tcp_offset))
    return {"format": "mjcf", "xml": SIX_DOF_MJCF, "frame": "tool", "joints": list(TABLE[name].joint_names)}


MODELS = ModelTable(TABLE, describe, default="small", defaults={"rate_hz": 250.0, "max_tool_step_m": 0.002},
                    max_rate_hz=500.0)


class TabledArm(ArmNode):
    """An arm whose joints follow their goal, everything else from the table."""

    models = MODELS

    class Config(ArmNode.Config):
        model: str = "small"  # any name, to see an unknown one named by the table
        tcp_offset: tuple[float, ...] | None = None

    def open(self) -> None:
        self.q = np.asarray(self.default_home())

    def read_joints(self):
        return {"joint_pos": self.q.copy()}

    def write_joints(self, joint_pos) -> None:
        self.q = np.array(joint_pos)


def test_joints_home_limits_and_description_come_from_the_table():
    with lifecycle(TabledArm(tcp_offset=(0, 0, 0.1, 0, 0, 0))) as arm:
        assert arm.joint_list == list(TABLE["small"].joint_names)
        np.testing.assert_allclose(arm.default_home(), TABLE["small"].home)
        lo, hi = arm.commander.lower, arm.commander.upper
        np.testing.assert_allclose(lo, [v[0] for v in TABLE["small"].limits])
        np.testing.assert_allclose(hi, [v[1] for v in TABLE["small"].limits])
        assert arm.robot_description()["joints"] == list(TABLE["small"].joint_names)
        assert described[-1] == ("small", (0, 0, 0.1, 0, 0, 0))


def test_the_station_narrows_the_table_limits():
    with lifecycle(TabledArm(joint_limits=[(-1.0, 1.0)] * 6)) as arm:
        np.testing.assert_allclose(arm.commander.upper, [1.0] * 6)
        np.testing.assert_allclose(arm.commander.lower, [-1.0] * 6)


def test_an_unknown_model_is_named():
    with pytest.raises(Exception, match="unknown model 'big'; known: small"):
        with lifecycle(TabledArm(model="big")):
            pass


def test_the_config_takes_the_model_the_defaults_and_the_rate_bound_from_the_table():
    class Config(ArmNode.Config):
        defaults = MODELS.defaults
        model: str = MODELS.field()

    c = Config()
    assert (c.model, c.rate_hz, c.max_tool_step_m) == ("small", 250.0, 0.002)
    kinds = ArmNode.Config.model_fields
    assert Config.model_fields["max_tool_step_m"].description == kinds["max_tool_step_m"].description
    assert Config.model_fields["model"].description == "which model: small"
    with pytest.raises(ValidationError, match="unknown model 'big'; known: small"):
        Config(model="big")
    with pytest.raises(ValidationError, match="rate_hz"):
        Config(rate_hz=600.0)


# -- without an IK solver: the published reach, and the extra that installs the solver -----------------------

@dataclass(frozen=True)
class ReachEntry(Entry):
    reach: float = 0.6
    shoulder_height: float = 0.2


REACH_TABLE = {"small": ReachEntry(*(getattr(TABLE["small"], f) for f in ("name", "joint_names", "home", "limits")))}
REACH_MODELS = ModelTable(REACH_TABLE, describe, default="small", ik_extra="rio-tabled[ik]")


class ReachArm(TabledArm):
    models = REACH_MODELS


class CartesianArm(ReachArm):
    """An arm whose controller takes poses, told to use RIO's IK instead (a vendor driver's eef_control = "ik")."""

    class Config(ReachArm.Config):
        native: bool = False

    @property
    def streams_poses(self) -> bool:
        return self.config.native

    def open(self) -> None:
        super().open()
        self.pose = np.array([0.3, 0.0, 0.4, 1.0, 0.0, 0.0, 0.0])

    def read_joints(self):
        return {**super().read_joints(), "eef_pose": self.pose.copy()}  # the controller measures it

    def write_pose(self, eef_pose) -> None:
        self.pose = np.array(eef_pose)


@pytest.fixture
def no_solver(monkeypatch):
    """`import mujoco` fails, as where rio-core[ik] is not installed."""
    monkeypatch.setitem(sys.modules, "mujoco", None)


def test_without_a_solver_the_box_is_the_published_reach_and_ik_names_the_plugins_extra(no_solver):
    from rio.errors import InvalidRequest
    from rio.kinematics.reach import reach_box_from_table

    assert REACH_MODELS.reach("small") == (0.6, 0.2) and MODELS.reach("small") is None
    with lifecycle(ReachArm()) as arm:
        assert arm.kinematics is None
        box = arm.workspace()
        assert box["source"] == "table"
        np.testing.assert_allclose(box["lower"], [-0.75, -0.75, -0.55])  # the reach plus 25%, around the shoulder
        np.testing.assert_allclose(box["upper"], [0.75, 0.75, 0.95])
        np.testing.assert_allclose(box["upper"], reach_box_from_table(0.6, 0.2)[1])
        assert np.isnan(arm.cycle()["eef_pose"]).all()
        with pytest.raises(InvalidRequest, match=r"no IK solver .*mujoco.*: pip install 'rio-tabled\[ik\]'"):
            arm.command_eef(np.array([0.3, 0.0, 0.3, 1.0, 0.0, 0.0, 0.0]), 0.0)
    with lifecycle(TabledArm()) as arm:  # no reach in the table: unbounded, the core's extra named
        assert arm.workspace()["source"] == "none"
        with pytest.raises(InvalidRequest, match=r"pip install 'rio-core\[ik\]'"):
            arm.command_eef(np.array([0.3, 0.0, 0.3, 1.0, 0.0, 0.0, 0.0]), 0.0)


def test_an_arm_told_to_use_rios_ik_refuses_to_open_without_the_solver(no_solver):
    with pytest.raises(ImportError, match=r"node '.*': no IK solver .*pip install 'rio-tabled\[ik\]'"):
        with lifecycle(CartesianArm()):
            pass
    with lifecycle(CartesianArm(native=True)) as arm:  # the controller's Cartesian control needs no solver
        assert arm.workspace()["source"] == "table" and arm.poses is not None


def test_the_reach_computed_on_the_model_wins_where_the_solver_is_installed():
    pytest.importorskip("mink")
    with lifecycle(ReachArm()) as arm:
        assert arm.kinematics is not None and arm.workspace()["source"] == "model"


def test_a_published_reach_is_a_positive_distance():
    from rio.kinematics.reach import reach_box_from_table

    with pytest.raises(ValueError, match="positive"):
        reach_box_from_table(0.0)
