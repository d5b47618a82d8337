"""`--policy NAME,key=value,...`: values are JSON where they parse (lists and objects included, commas
inside them kept), else strings; a pair without `=` is one error quoting it."""

from __future__ import annotations

import pytest

from rio.errors import ConfigError
from rio.policy.resolve import parse_policy_arg


def test_values_may_be_json_lists_objects_and_quoted_strings_with_commas():
    name, fields = parse_policy_arg('onnx.locomotion,path=/m.onnx,command=[0.3, 0, 0],obs={"a": [1, 2]},'
                                    'tag="a,b",rate=50,on=true')
    assert name == "onnx.locomotion"
    assert fields == {"path": "/m.onnx", "command": [0.3, 0, 0], "obs": {"a": [1, 2]}, "tag": "a,b", "rate": 50,
                      "on": True}


def test_a_pair_without_a_value_is_named():
    with pytest.raises(ConfigError, match="'threshold' is not key=value"):
        parse_policy_arg("onnx.locomotion,threshold")
