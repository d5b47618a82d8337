"""Encoding of API calls and replies that cross a process or machine boundary.

msgpack plus one extension type for numpy arrays (dtype string, shape, raw bytes). Decoding never
executes code: unlike pickle, a hostile or corrupted peer can at worst produce a decode error.
Object arrays are refused at both ends.
"""

from __future__ import annotations

import traceback
from typing import Any

import msgpack
import numpy as np

_EXT_NDARRAY = 1


def _default(obj: Any) -> Any:
    if isinstance(obj, (np.ndarray, np.generic)):
        arr = np.asarray(obj)
        if arr.dtype.kind not in "biufcSU" or arr.dtype.hasobject:
            raise TypeError(f"cannot send numpy dtype {arr.dtype} (object arrays are refused)")
        arr = np.ascontiguousarray(arr)
        head = msgpack.packb([arr.dtype.str, list(arr.shape), isinstance(obj, np.generic)])
        return msgpack.ExtType(_EXT_NDARRAY, len(head).to_bytes(2, "little") + head + arr.tobytes())
    if isinstance(obj, (set, frozenset)):
        return list(obj)
    raise TypeError(f"cannot send object of type {type(obj).__name__} (send arrays, numbers, str, lists, dicts)")


def _ext_hook(code: int, data: bytes) -> Any:
    if code != _EXT_NDARRAY:
        raise ValueError(f"unknown extension type {code}")
    n = int.from_bytes(data[:2], "little")
    dtype_str, shape, is_scalar = msgpack.unpackb(data[2:2 + n])
    dt = np.dtype(dtype_str)
    if dt.hasobject:
        raise ValueError("object arrays are refused")
    arr = np.frombuffer(data, dtype=dt, offset=2 + n).reshape(shape).copy()
    return arr[()] if is_scalar else arr


def pack(obj: Any) -> bytes:
    return msgpack.packb(obj, default=_default, use_bin_type=True)


def unpack(data: bytes | memoryview) -> Any:
    return msgpack.unpackb(data, ext_hook=_ext_hook, raw=False, strict_map_key=False)


# -- API call messages -------------------------------------------------------------------------------
def pack_call(call_id: int, method: str, args: tuple | list, kwargs: dict) -> bytes:
    return pack([call_id, method, list(args), kwargs])


def unpack_call(data: bytes | memoryview) -> tuple[int, str, list, dict]:
    msg = unpack(data)
    if not (isinstance(msg, list) and len(msg) == 4 and isinstance(msg[1], str)
            and isinstance(msg[2], list) and isinstance(msg[3], dict)):
        raise ValueError("malformed API call message")
    return msg[0], msg[1], msg[2], msg[3]


def pack_reply(call_id: int, ok: bool, value: Any) -> bytes:
    try:
        return pack([call_id, ok, value])
    except TypeError as e:  # an unsendable return value becomes an error on the client
        return pack([call_id, False, ["TypeError", f"return value not sendable: {e}", ""]])


def error_payload(exc: BaseException) -> list[str]:
    return [type(exc).__name__, str(exc), "".join(traceback.format_exception(exc))]


def unpack_reply(data: bytes | memoryview) -> tuple[int, bool, Any]:
    msg = unpack(data)
    if not (isinstance(msg, list) and len(msg) == 3):
        raise ValueError("malformed API reply message")
    return msg[0], bool(msg[1]), msg[2]
