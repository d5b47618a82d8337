"""`ModelTable`: a vendor arm's joints, home, limits and robot description come from its plugin's model
table, picked by the station's `model`; the station's own fields still narrow them; the table's defaults and
rate bound are the config's, with the kind's descriptions."""

from __future__ import annotations

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
