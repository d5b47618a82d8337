"""`ModelTableArm`: a vendor arm's joints, home, limits and robot description come from its plugin's
model table, picked by the station's `model`; the station's own fields still narrow them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from rio.fakes.arms import SIX_DOF_MJCF, FakeArm
from rio.interfaces import ModelTableArm
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


def lookup(name: str) -> Entry:
    if name not in TABLE:
        raise KeyError(f"unknown model '{name}'; known: {', '.join(TABLE)}")
    return TABLE[name]


def describe(name: str, tcp_offset) -> dict:
    described.append((name, tcp_offset))
    return {"format": "mjcf", "xml": SIX_DOF_MJCF, "frame": "tool", "joints": list(TABLE[name].joint_names)}


class TabledArm(ModelTableArm, FakeArm):
    lookup_model = staticmethod(lookup)
    describe_model = staticmethod(describe)

    class Config(FakeArm.Config):
        model: str = "small"
        tcp_offset: tuple[float, ...] | None = None


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
