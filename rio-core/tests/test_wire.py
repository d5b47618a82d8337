"""The API-call codec: numpy-aware msgpack that never executes code from the peer."""

import pickle

import numpy as np
import pytest

from rio.runtime import wire


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


def _flat(message: wire.Message) -> bytes:
    """What a transport writes for a message: the head, then each array's bytes."""
    head, arrays = message
    return head + b"".join(a.tobytes() for a in arrays)


@pytest.mark.parametrize("arrays", [
    (np.arange(2048, dtype=np.uint8),),
    (np.arange(12.0).reshape(3, 4), np.array([True, False]), np.zeros((0, 3), np.int32)),
    (np.array(2.5), np.arange(4, dtype=">i4"), np.ones(3, np.complex64)),
    (),
])
def test_array_calls_use_the_fixed_form_and_round_trip(arrays):
    message = wire.call_message("ik", arrays, {})
    assert message[0][0] == wire.MSG_ARRAY_CALL
    method, args, kwargs = wire.read_call(memoryview(_flat(message)))
    assert method == "ik" and kwargs == {} and len(args) == len(arrays)
    for got, sent in zip(args, arrays, strict=True):
        assert got.dtype == sent.dtype and got.shape == sent.shape and got.flags.writeable
        np.testing.assert_array_equal(got, sent)


def test_array_reply_is_copied_out_of_the_buffer():
    buf = bytearray(_flat(wire.reply_message(True, np.arange(6.0).reshape(2, 3))))
    ok, value = wire.read_reply(buf)
    buf[-8:] = bytes(8)  # the transport reuses its buffer for the next message
    assert ok and value.shape == (2, 3) and value[1, 2] == 5.0


@pytest.mark.parametrize("args,kwargs", [
    ((np.arange(3.0),), {"speed": 0.5}),           # keyword arguments
    ((np.arange(6.0).reshape(2, 3).T,), {}),       # not C-contiguous
    ((np.array(["a", "b"]),), {}),                 # not a plain-number dtype
    ((1.0, np.arange(3.0)), {}),                   # not all arrays
    ((np.float64(1.0),), {}),                      # numpy scalar, not an array
])
def test_other_calls_fall_back_to_msgpack_and_round_trip(args, kwargs):
    message = wire.call_message("move", args, kwargs)
    assert message[0][0] == wire.MSG_PACKED and message[1] == ()
    method, got, got_kwargs = wire.read_call(_flat(message))
    assert method == "move" and got_kwargs == kwargs
    for g, a in zip(got, args, strict=True):
        np.testing.assert_array_equal(g, a)


def test_error_and_non_array_replies_round_trip():
    assert wire.read_reply(_flat(wire.reply_message(True, {"q": [1, 2]}))) == (True, {"q": [1, 2]})
    ok, err = wire.read_reply(_flat(wire.reply_message(False, wire.error_payload(ValueError("bad q")))))
    assert ok is False and err[0] == "ValueError" and err[1] == "bad q"


def test_malformed_array_messages_are_refused():
    good = _flat(wire.call_message("ik", (np.arange(4.0),), {}))
    with pytest.raises(ValueError, match="past the end"):
        wire.read_call(good[:-1])
    with pytest.raises(ValueError, match="trailing"):
        wire.read_call(good + b"\x00")
    with pytest.raises(ValueError, match="kind"):
        wire.read_call(b"\x07" + good[1:])
    with pytest.raises(ValueError, match="kind"):
        wire.read_reply(b"")
    reply = _flat(wire.reply_message(True, np.arange(4.0)))
    with pytest.raises(ValueError, match="kind"):
        wire.read_call(reply)  # a reply is not a call
    with pytest.raises(ValueError, match="dtype"):
        wire.read_call(good.replace(b"<f8", b"<fX"))  # not a dtype
    with pytest.raises(ValueError, match="dtype"):
        wire.read_call(good.replace(b"<f8", b"|O8"))  # object arrays are never built
    for cut in range(1, 12):  # a header cut short anywhere is an error, never an IndexError
        with pytest.raises(ValueError):
            wire.read_call(good[:cut])
