"""The API-call codec: numpy-aware msgpack that never executes code from the peer."""

import pickle

import numpy as np
import pytest
from rio import wire


def test_round_trip_arrays_scalars_and_containers():
    obj = {"a": np.arange(12, dtype=np.int16).reshape(3, 4), "f": np.float32(1.5), "n": None,
           "l": [1, "two", 3.0, b"four"], "e": np.zeros((0, 3)), "t": np.asfortranarray(np.eye(2))}
    back = wire.unpack(wire.pack(obj))
    np.testing.assert_array_equal(back["a"], obj["a"])
    assert back["a"].dtype == np.int16 and back["a"].flags.writeable
    assert isinstance(back["f"], np.float32) and back["f"] == 1.5
    assert back["l"] == [1, "two", 3.0, b"four"] and back["n"] is None
    assert back["e"].shape == (0, 3)
    np.testing.assert_array_equal(back["t"], np.eye(2))


def test_objects_are_refused_both_ways():
    with pytest.raises(TypeError, match="cannot send"):
        wire.pack(object())
    with pytest.raises(TypeError):
        wire.pack(np.array([object()]))
    with pytest.raises(ValueError):
        wire.unpack(pickle.dumps({"a": 1}))  # pickle bytes are not a valid message


def test_call_and_reply_messages():
    cid, m, a, k = wire.unpack_call(wire.pack_call(7, "home", (1.0,), {"speed": 0.1}))
    assert (cid, m, a, k) == (7, "home", [1.0], {"speed": 0.1})
    with pytest.raises(ValueError, match="malformed"):
        wire.unpack_call(wire.pack([1, 2]))
    rid, ok, val = wire.unpack_reply(wire.pack_reply(7, True, object()))
    assert rid == 7 and ok is False and val[0] == "TypeError"
