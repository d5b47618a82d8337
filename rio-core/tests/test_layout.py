"""Layouts: example dicts become fixed records; validation names the node and the field."""

import numpy as np
import pytest

from rio.errors import InvalidRequest
from rio.runtime.layout import Layout


def make():
    return Layout({"q": np.zeros(6, np.float32), "mode": 0, "on": False}, owner="arm", what="request")


def test_record_fields_and_timestamp_added():
    lay = make()
    assert lay.names == ("q", "mode", "on", "timestamp")
    assert lay.dtype["q"].shape == (6,) and lay.dtype["q"].base == np.float32
    rec = lay.encode({"q": np.ones(6), "mode": 2, "on": True}, fill_timestamp=12.5)
    d = lay.to_dict(rec)
    assert d["timestamp"] == 12.5 and d["mode"] == 2 and bool(d["on"]) is True
    np.testing.assert_array_equal(d["q"], np.ones(6, np.float32))


def test_bytes_round_trip_and_size_check():
    lay = make()
    rec = lay.encode({"q": np.arange(6), "mode": 1, "on": True, "timestamp": 3.0})
    back = lay.decode_bytes(rec.tobytes())
    np.testing.assert_array_equal(back["q"], np.arange(6, dtype=np.float32))
    with pytest.raises(InvalidRequest, match="bytes"):
        lay.decode_bytes(rec.tobytes()[:-1])


@pytest.mark.parametrize("values, field, words", [
    ({"q": np.zeros(5), "mode": 0, "on": False}, "q", "shape"),
    ({"q": np.zeros(6), "mode": 0.5, "on": False}, "mode", "dtype"),
    ({"q": np.zeros(6), "on": False}, "mode", "missing"),
    ({"q": np.zeros(6), "mode": 0, "on": False, "extra": 1}, "extra", "unknown"),
    ({"q": np.array([0, 0, 0, np.nan, 0, 0]), "mode": 0, "on": False}, "q", "NaN"),
])
def test_validation_names_node_and_field(values, field, words):
    with pytest.raises(InvalidRequest) as ei:
        make().encode(values, fill_timestamp=0.0)
    assert ei.value.node == "arm" and ei.value.field == field
    assert words in str(ei.value) and "node 'arm'" in str(ei.value)


def test_non_dict_and_object_examples_refused():
    with pytest.raises(InvalidRequest, match="expected a dict"):
        make().encode([1, 2, 3])
    with pytest.raises(TypeError, match="only numeric"):
        Layout({"name": "text"}, owner="cam")


def test_fingerprint_tracks_layout():
    a, b = make(), make()
    c = Layout({"q": np.zeros(7, np.float32), "mode": 0, "on": False}, owner="arm")
    assert a.fingerprint == b.fingerprint != c.fingerprint


@pytest.mark.parametrize("example, value, words", [
    (np.int8(0), 300, "value 300 does not fit int8"),
    (np.int8(0), -129, "value -129 does not fit int8"),
    (np.int64(0), np.uint64(2**63), "does not fit int64"),
    (np.uint16(0), np.array(-1), "value -1 does not fit uint16"),
    (np.zeros(2, np.float32), np.array([1.0, 1e300]), "beyond float32's range"),
])
def test_a_value_that_does_not_fit_its_field_is_refused_not_wrapped(example, value, words):
    """Seen by the hardening probe: 300 into int8 arrived as 44, 2**63 into int64 wrapped negative, 1e300
    into float32 became inf."""
    lay = Layout({"x": example}, owner="arm", what="request")
    with pytest.raises(InvalidRequest, match=words) as ei:
        lay.encode({"x": value}, fill_timestamp=0.0)
    assert ei.value.field == "x"


def test_values_that_fit_a_narrower_field_pass_unchanged():
    lay = Layout({"small": np.int8(0), "f": np.zeros(2, np.float32), "u": np.uint8(0)}, owner="arm")
    d = lay.to_dict(lay.encode({"small": -128, "f": np.array([1.5, -3e38]), "u": np.int64(255)}, fill_timestamp=0.0))
    assert d["small"] == -128 and d["u"] == 255 and d["f"][1] == np.float32(-3e38)
