"""`rio.config`: a renamed field or value keeps its old name working for one release, saying so once in
the log; `defaults` gives inherited fields other defaults without losing their constraints."""

from __future__ import annotations

import logging
from typing import Literal

import pytest
from pydantic import Field, ValidationError

from rio.config import Config


class Base(Config):
    renamed = {"max_step_m": "max_tool_step_m"}
    rate_hz: float = Field(100.0, gt=0, description="loop rate (Hz)")
    max_tool_step_m: float = Field(0.005, gt=0, description="largest tool travel per cycle (m)")


class Vendor(Base):
    renamed_values = {"eef_control": {"controller": "native"}}
    eef_control: Literal["native", "ik"] = "native"


def test_an_old_field_name_is_the_new_field_and_says_so_once(caplog):
    class Arm(Vendor):  # a class of its own: the notice is once per process and class
        pass

    with caplog.at_level(logging.WARNING, logger="rio.config"):
        assert Arm(max_step_m=0.002).max_tool_step_m == 0.002  # the base's rename holds in a subclass
        assert Arm.model_validate({"max_step_m": 0.003}).max_tool_step_m == 0.003
    lines = [r.getMessage() for r in caplog.records]
    assert lines == ["test_an_old_field_name_is_the_new_field_and_says_so_once.<locals>.Arm: 'max_step_m' is now "
                     "'max_tool_step_m' (the old name is accepted until the next release)"]


def test_an_old_value_is_the_new_value(caplog):
    with caplog.at_level(logging.WARNING, logger="rio.config"):
        assert Vendor(eef_control="controller").eef_control == "native"
    assert "eef_control = 'controller' is now 'native'" in caplog.text
    with pytest.raises(ValidationError, match="eef_control"):
        Vendor(eef_control="controler")  # not a renamed value: still an error


def test_both_names_at_once_is_an_error_naming_both():
    with pytest.raises(ValidationError, match="max_step_m and max_tool_step_m are one field"):
        Vendor(max_step_m=0.002, max_tool_step_m=0.003)


def test_defaults_keep_type_constraints_and_description():
    class Fast(Vendor):
        defaults = {"rate_hz": Field(250.0, le=500), "max_tool_step_m": 0.002}

    class Faster(Fast):  # a subclass keeps them
        pass

    for model in (Fast, Faster):
        c = model()
        assert (c.rate_hz, c.max_tool_step_m) == (250.0, 0.002)
        assert model.model_fields["rate_hz"].description == "loop rate (Hz)"
        assert model(max_step_m=0.001).max_tool_step_m == 0.001  # renames still apply
        for bad in ({"rate_hz": 600.0}, {"rate_hz": -1.0}, {"max_tool_step_m": 0.0}):
            with pytest.raises(ValidationError, match=next(iter(bad))):
                model(**bad)
    assert Vendor().rate_hz == 100.0  # the base itself is unchanged
    with pytest.raises(KeyError, match="has no field 'rate'"):
        class Typo(Vendor):
            defaults = {"rate": 1.0}


def test_a_station_file_with_an_old_arm_field_still_loads():
    from rio.station import parse_station

    st = parse_station({"name": "s", "components": {"arm": {"driver": "rio.fake_arm", "max_step_m": 0.01,
                                                            "max_step_eef_rad": 0.2}}})
    c = st.components["arm"].config
    assert (c.max_tool_step_m, c.max_tool_step_rad) == (0.01, 0.2)
