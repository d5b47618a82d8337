"""Encoding of API calls and replies that cross a process or machine boundary.

msgpack plus one extension type for numpy arrays (dtype string, shape, raw bytes). Decoding never
executes code: unlike pickle, a hostile or corrupted peer can at worst produce a decode error.
Object arrays are refused at both ends.
"""

from __future__ import annotations

import struct
import threading
import traceback
from typing import Any

import msgpack
import numpy as np

_EXT_NDARRAY = 1
_SEND_KINDS = frozenset("biufcSU")
_DTYPES: dict[bytes, np.dtype] = {}


def _default(obj: Any) -> Any:
    """ndarray / numpy scalar -> ext(1): [len(dtype str), ndim, is_scalar] dtype-str shape(u32...) data.
    A flat struct header rather than nested msgpack: this runs on every API call."""
    if isinstance(obj, (np.ndarray, np.generic)):
        arr = obj if isinstance(obj, np.ndarray) else np.asarray(obj)
        dt = arr.dtype
        if dt.kind not in _SEND_KINDS or dt.hasobject:
            raise TypeError(f"cannot send numpy dtype {dt} (object arrays are refused)")
        if not arr.flags.c_contiguous:
            arr = np.ascontiguousarray(arr)
        ds = dt.str.encode()
        head = bytes((len(ds), arr.ndim, isinstance(obj, np.generic))) + ds + struct.pack(f"<{arr.ndim}I", *arr.shape)
        return msgpack.ExtType(_EXT_NDARRAY, b"".join((head, arr.data.cast("B") if arr.ndim and arr.size else arr.tobytes())))
    if isinstance(obj, (set, frozenset)):
        return list(obj)
    raise TypeError(f"cannot send object of type {type(obj).__name__} (send arrays, numbers, str, lists, dicts)")


def _dtype(ds: bytes) -> np.dtype:
    dt = _DTYPES.get(ds)
    if dt is None:
        dt = np.dtype(ds.decode())
        if dt.hasobject or dt.kind not in _SEND_KINDS:
            raise ValueError(f"refused dtype {dt}")
        if len(_DTYPES) < 256:
            _DTYPES[ds] = dt
    return dt


def _ext_hook(code: int, data: bytes) -> Any:
    if code != _EXT_NDARRAY:
        raise ValueError(f"unknown extension type {code}")
    n, ndim, is_scalar = data[0], data[1], data[2]
    dt = _dtype(data[3:3 + n])
    off = 3 + n
    shape = struct.unpack_from(f"<{ndim}I", data, off)
    arr = np.frombuffer(data, dtype=dt, offset=off + 4 * ndim).reshape(shape).copy()
    return arr[()] if is_scalar else arr


_local = threading.local()


def pack(obj: Any) -> bytes:
    packer = getattr(_local, "packer", None)
    if packer is None:  # a Packer per thread: creating one per message costs more than packing 2 KB
        packer = _local.packer = msgpack.Packer(default=_default, use_bin_type=True)
    try:
        return packer.pack(obj)
    except BaseException:
        packer.reset()
        raise


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
