"""Property-based tests (hypothesis, a bounded budget per test): what a hostile peer or a damaged file
can hand the decoders that face them. Each either decodes, or raises the one error kind its callers
catch (ValueError for wire messages, InvalidRequest for records, ConfigError for station files and
dataset metadata) — never anything else, never a hang."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rio.errors import ConfigError, InvalidRequest
from rio.runtime import wire
from rio.runtime.layout import Layout

BUDGET = settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])

scalars = st.one_of(st.none(), st.booleans(), st.integers(-(2**63), 2**63 - 1),
                    st.floats(allow_nan=False), st.text(max_size=20), st.binary(max_size=20))
values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                       st.dictionaries(st.text(max_size=8), inner, max_size=4)),
                      max_leaves=12)


@BUDGET
@given(st.integers(0, 2**31), st.text(min_size=1, max_size=20), st.lists(values, max_size=4),
       st.dictionaries(st.text(max_size=8), values, max_size=4))
def test_api_calls_round_trip(call_id, method, args, kwargs):
    assert wire.unpack_call(wire.pack_call(call_id, method, args, kwargs)) == (call_id, method, args, kwargs)


@BUDGET
@given(st.binary(max_size=300))
def test_any_bytes_as_an_api_call_or_reply_are_a_value_error_or_a_message(data):
    for decode in (wire.unpack_call, wire.unpack_reply, wire.read_call, wire.read_reply):
        try:
            decode(data)
        except ValueError:
            pass


@BUDGET
@given(st.lists(st.integers(0, 255), min_size=1, max_size=40), st.data())
def test_a_call_with_bytes_flipped_is_a_value_error_or_a_message(flips, data):
    msg = bytearray(wire.pack_call(7, "command", [np.arange(6.0), {"gain": 2.5}], {"mode": "joint"}))
    for f in flips:
        msg[data.draw(st.integers(0, len(msg) - 1))] = f
    try:
        wire.unpack_call(bytes(msg))
    except ValueError:
        pass


ARM = Layout({"joint_pos": np.zeros(6), "mode": np.int8(0), "gain": np.float32(0.0), "on": False}, owner="arm",
             what="request")
field_values = st.one_of(scalars, st.lists(st.floats(), max_size=8), st.lists(st.integers(-(2**70), 2**70),
                                                                                max_size=8))


@BUDGET
@given(st.dictionaries(st.sampled_from(["joint_pos", "mode", "gain", "on", "extra"]), field_values, max_size=5))
def test_any_request_either_encodes_exactly_or_is_refused_by_field(values_):
    try:
        rec = ARM.encode(values_, fill_timestamp=0.0)
    except InvalidRequest as e:
        assert e.node == "arm"
        return
    d = ARM.to_dict(rec)
    assert np.all(np.isfinite(d["joint_pos"])) and math.isfinite(float(d["gain"]))
    assert d["mode"] == values_["mode"]  # never wrapped


@BUDGET
@given(st.binary(max_size=200))
def test_any_bytes_as_a_request_record_are_refused_or_finite(data):
    try:
        rec = ARM.decode_bytes(data)
        ARM.check_record(rec)
    except InvalidRequest:
        return
    assert np.all(np.isfinite(rec["joint_pos"]))


toml_text = st.one_of(st.text(max_size=300), st.builds(
    lambda name, rate, comps: f'name = {name!r}\nrate_hz = {rate}\n' + "".join(
        f'[components.{r}]\ndriver = {d!r}\n' for r, d in comps),
    st.text(max_size=10), st.one_of(st.integers(-5, 1000), st.floats(allow_nan=True).map(repr)),
    st.lists(st.tuples(st.sampled_from(["arm", "gripper", "front_camera", "x_sensor", "arm2", "bogus"]),
                       st.sampled_from(["rio.fake_arm", "rio.fake_gripper", "rio.fake_camera", "nope"])),
             max_size=4)))


@BUDGET
@given(toml_text)
def test_any_station_text_is_a_station_or_a_config_error(text):
    from rio.station import parse_station
    from rio.toml import parse_toml

    try:
        parse_station(parse_toml(text, "prop.toml"), source="prop.toml")
    except ConfigError:
        pass


@BUDGET
@given(st.binary(max_size=300))
def test_any_bytes_as_dataset_metadata_are_a_config_error_or_json(tmp_path_factory, data):
    from rio.recording.durable import read_json

    path = tmp_path_factory.mktemp("meta") / "dataset.json"
    path.write_bytes(data)
    try:
        read_json(path)
    except ConfigError as e:
        assert str(path) in str(e)


@pytest.mark.parametrize("depth", [10, 5000])
def test_deeply_nested_wire_messages_are_refused_or_decoded(depth):
    data = b"\x91" * depth + b"\xc0"  # [[[...[nil]...]]]
    try:
        wire.unpack(data)
    except ValueError:
        pass
