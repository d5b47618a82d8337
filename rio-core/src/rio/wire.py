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
# Headers of recently seen (dtype, shape) pairs, both ways: robot traffic repeats a few layouts
# forever, and building/parsing a header cost more than copying a 2 KB payload.
_HEADS: dict[tuple, bytes] = {}
_PARSED: dict[bytes, tuple[np.dtype, tuple[int, ...], bool]] = {}
_CACHE_MAX = 512


def _head(arr: np.ndarray, is_scalar: bool) -> bytes:
    key = (arr.dtype, arr.shape, is_scalar)
    head = _HEADS.get(key)
    if head is None:
        dt = arr.dtype
        if dt.kind not in _SEND_KINDS or dt.hasobject:
            raise TypeError(f"cannot send numpy dtype {dt} (object arrays are refused)")
        ds = dt.str.encode()
        head = bytes((len(ds), arr.ndim, is_scalar)) + ds + struct.pack(f"<{arr.ndim}I", *arr.shape)
        if len(_HEADS) < _CACHE_MAX:
            _HEADS[key] = head
    return head


def _default(obj: Any) -> Any:
    """ndarray / numpy scalar -> ext(1): [len(dtype str), ndim, is_scalar] dtype-str shape(u32...) data."""
    if isinstance(obj, np.ndarray):
        if not obj.flags.c_contiguous:
            obj = np.ascontiguousarray(obj)
        return msgpack.ExtType(_EXT_NDARRAY, _head(obj, False) + obj.tobytes())
    if isinstance(obj, np.generic):
        arr = np.asarray(obj)
        return msgpack.ExtType(_EXT_NDARRAY, _head(arr, True) + arr.tobytes())
    if isinstance(obj, (set, frozenset)):
        return list(obj)
    raise TypeError(f"cannot send object of type {type(obj).__name__} (send arrays, numbers, str, lists, dicts)")


def _parse_head(head: bytes) -> tuple[np.dtype, tuple[int, ...], bool]:
    parsed = _PARSED.get(head)
    if parsed is None:
        n, ndim, is_scalar = head[0], head[1], bool(head[2])
        dt = np.dtype(head[3:3 + n].decode())
        if dt.hasobject or dt.kind not in _SEND_KINDS:
            raise ValueError(f"refused dtype {dt}")
        parsed = (dt, struct.unpack_from(f"<{ndim}I", head, 3 + n), is_scalar)
        if len(_PARSED) < _CACHE_MAX:
            _PARSED[head] = parsed
    return parsed


def _ext_hook(code: int, data: bytes) -> Any:
    if code != _EXT_NDARRAY:
        raise ValueError(f"unknown extension type {code}")
    hlen = 3 + data[0] + 4 * data[1]
    dt, shape, is_scalar = _parse_head(data[:hlen])
    arr = np.frombuffer(data, dtype=dt, offset=hlen).reshape(shape).copy()  # copy: writable, owns memory
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
