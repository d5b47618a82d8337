"""Encoding of API calls and replies that cross a process or machine boundary.

msgpack plus one extension type for numpy arrays (dtype string, shape, raw bytes). Decoding never
executes code: unlike pickle, a hostile or corrupted peer can at worst produce a decode error.
Object arrays are refused at both ends.
"""

from __future__ import annotations

import re
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
_PARSED: dict[bytes, tuple[np.dtype, tuple[int, ...], bool, int]] = {}
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


def _parse_head(head: bytes) -> tuple[np.dtype, tuple[int, ...], bool, int]:
    """(dtype, shape, is_scalar, element count) of an array header."""
    parsed = _PARSED.get(head)
    if parsed is None:
        n, ndim, is_scalar = head[0], head[1], bool(head[2])
        try:
            dt = np.dtype(head[3:3 + n].decode())
        except (TypeError, ValueError, UnicodeDecodeError):
            raise ValueError(f"unknown dtype {head[3:3 + n]!r}") from None
        if dt.hasobject or dt.kind not in _SEND_KINDS:
            raise ValueError(f"refused dtype {dt}")
        shape = struct.unpack_from(f"<{ndim}I", head, 3 + n)
        parsed = (dt, shape, is_scalar, int(np.prod(shape, dtype=np.int64)))
        if len(_PARSED) < _CACHE_MAX:
            _PARSED[head] = parsed
    return parsed


def _head_at(buf: Any, off: int) -> tuple[np.dtype, tuple[int, ...], bool, int, int]:
    """`_parse_head` of the array header starting at `buf[off]`, plus the offset just past it."""
    try:
        end = off + 3 + buf[off] + 4 * buf[off + 1]
        return (*_parse_head(bytes(buf[off:end])), end)
    except (IndexError, struct.error):
        raise ValueError("malformed array header") from None


def _read_array(buf: Any, off: int) -> tuple[Any, int]:
    """The array whose header starts at `buf[off]`, copied out (writable, owns its memory), and the
    offset just past its data."""
    dt, shape, is_scalar, count, off = _head_at(buf, off)
    end = off + count * dt.itemsize
    if end > len(buf):
        raise ValueError("array data runs past the end of the message")
    arr = np.frombuffer(buf, dtype=dt, count=count, offset=off).reshape(shape).copy()
    return (arr[()] if is_scalar else arr), end


def _ext_hook(code: int, data: bytes) -> Any:
    if code != _EXT_NDARRAY:
        raise ValueError(f"unknown extension type {code}")
    arr, end = _read_array(data, 0)
    if end != len(data):
        raise ValueError("array extension has trailing bytes")
    return arr


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
    """A message's value; anything malformed is a ValueError (what every server catches)."""
    try:
        return msgpack.unpackb(data, ext_hook=_ext_hook, raw=False, strict_map_key=False)
    except ValueError:
        raise
    except Exception as e:  # e.g. a list as a map key (TypeError: unhashable), found by test_properties.py
        raise ValueError(f"malformed message ({type(e).__name__}: {e})") from None


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
    """An exception as a reply: type, message and traceback, for a client on this machine."""
    return [type(exc).__name__, str(exc), "".join(traceback.format_exception(exc))]


# An absolute path in an error message: POSIX (/a/b) or Windows (C:\a\b), up to whitespace or a quote.
_PATH = re.compile(r"(?<![\w.:/])(?:/|[A-Za-z]:\\)[^\s'\"]*[/\\]([^\s'\"/\\]+)")


def remote_error_payload(exc: BaseException) -> list[str]:
    """An exception as a reply that leaves the machine: type and message only, absolute paths cut to
    their last part (`.../calib.yaml`), no traceback: a peer learns what failed, not how the server's
    disk is laid out. The server's own log keeps the traceback."""
    return [type(exc).__name__, _PATH.sub(r".../\1", str(exc)), ""]


def unpack_reply(data: bytes | memoryview) -> tuple[int, bool, Any]:
    msg = unpack(data)
    if not (isinstance(msg, list) and len(msg) == 3):
        raise ValueError("malformed API reply message")
    return msg[0], bool(msg[1]), msg[2]


# -- fixed binary form for array calls ---------------------------------------------------------------
# The common remote call takes arrays and returns an array (`ik(target) -> q`, `echo(x)`). msgpack
# spends ~2 us per message on that in Python (the `default` hook, an ExtType, two copies). Here a
# message is one cached header plus the arrays' own memory, which the transport copies straight into
# its buffer; decoding is one cache lookup and one copy per array. Any other call or reply is msgpack.
#
#   kind u8 | header length u16 | header: method length u8, method, array count u8, array headers | data
#
# A message is `(head, arrays)`: `head` is bytes (kind, header; or kind and a msgpack body) and the
# arrays' data follows it back to back.
MSG_PACKED, MSG_ARRAY_CALL, MSG_ARRAY_REPLY = 0, 1, 2
_ARRAY_KINDS = frozenset("biufc")  # dtypes whose memory is plain bytes
_ARRAY_HEADS: dict[tuple, bytes] = {}
_ARRAY_SPECS: dict[bytes, tuple[str, tuple]] = {}
_PACKED = bytes((MSG_PACKED,))
_NO_ARRAYS: tuple = ()
Message = tuple[bytes, tuple]


def _array_head(kind: int, method: str, arrays: tuple | list) -> bytes | None:
    """Cached `kind | length | header` for these arrays, or None if they cannot use this form."""
    key = (kind, method, *[(a.dtype, a.shape) for a in arrays])
    head = _ARRAY_HEADS.get(key)
    if head is None:
        name = method.encode()
        if len(name) > 255 or len(arrays) > 255 or any(a.dtype.kind not in _ARRAY_KINDS for a in arrays):
            return None
        header = bytes((len(name),)) + name + bytes((len(arrays),)) + b"".join(_head(a, False) for a in arrays)
        if len(header) > 0xFFFF:
            return None
        head = bytes((kind,)) + struct.pack("<H", len(header)) + header
        if len(_ARRAY_HEADS) < _CACHE_MAX:
            _ARRAY_HEADS[key] = head
    return head


def call_message(method: str, args: tuple | list, kwargs: dict) -> Message:
    if not kwargs and all(type(a) is np.ndarray and a.flags.c_contiguous for a in args):
        head = _array_head(MSG_ARRAY_CALL, method, args)
        if head is not None:
            return head, tuple(args)
    return _PACKED + pack_call(0, method, args, kwargs), _NO_ARRAYS


def reply_message(ok: bool, value: Any) -> Message:
    """A reply: the return value, or `error_payload(exc)` when not ok."""
    if ok and type(value) is np.ndarray and value.flags.c_contiguous:
        head = _array_head(MSG_ARRAY_REPLY, "", (value,))
        if head is not None:
            return head, (value,)
    return _PACKED + pack_reply(0, ok, value), _NO_ARRAYS


def _array_specs(header: bytes) -> tuple[str, tuple]:
    """(method, ((dtype, shape, count, nbytes), ...)) of an array-message header, cached."""
    specs = _ARRAY_SPECS.get(header)
    if specs is None:
        try:
            mlen = header[0]
            method = header[1:1 + mlen].decode()
            nargs = header[1 + mlen]
        except (IndexError, UnicodeDecodeError):
            raise ValueError("malformed array message header") from None
        off, arrays = 2 + mlen, []
        for _ in range(nargs):
            dt, shape, _, count, off = _head_at(header, off)
            arrays.append((dt, shape, count, count * dt.itemsize))
        if off != len(header):
            raise ValueError("malformed array message header")
        specs = (method, tuple(arrays))
        if len(_ARRAY_SPECS) < _CACHE_MAX:
            _ARRAY_SPECS[header] = specs
    return specs


def _read_arrays(buf: Any) -> tuple[str, list]:
    if len(buf) < 3:
        raise ValueError("array message shorter than its header")
    hlen = buf[1] | buf[2] << 8
    header = bytes(buf[3:3 + hlen])
    method, specs = _ARRAY_SPECS.get(header) or _array_specs(header)
    off, end, out = 3 + hlen, len(buf), []
    for dt, shape, count, nbytes in specs:
        if off + nbytes > end:
            raise ValueError("array data runs past the end of the message")
        arr = np.frombuffer(buf, dt, count, off)
        out.append((arr if len(shape) == 1 else arr.reshape(shape)).copy())  # own memory, writable
        off += nbytes
    if off != end:
        raise ValueError("array message has trailing bytes")
    return method, out


def read_call(buf: Any) -> tuple[str, list, dict]:
    """Decode a `call_message` from any buffer (bytes, a memoryview of shared memory). Arrays are
    copied out, so the buffer may be reused as soon as this returns."""
    kind = buf[0] if len(buf) else -1
    if kind == MSG_ARRAY_CALL:
        method, args = _read_arrays(buf)
        return method, args, {}
    if kind == MSG_PACKED:
        _, method, args, kwargs = unpack_call(buf[1:])
        return method, args, kwargs
    raise ValueError(f"unknown API call message kind {kind}")


def read_reply(buf: Any) -> tuple[bool, Any]:
    """Decode a `reply_message` into (ok, value or error payload)."""
    kind = buf[0] if len(buf) else -1
    if kind == MSG_ARRAY_REPLY:
        _, values = _read_arrays(buf)
        if len(values) != 1:
            raise ValueError("array reply must hold exactly one array")
        return True, values[0]
    if kind == MSG_PACKED:
        _, ok, value = unpack_reply(buf[1:])
        return ok, value
    raise ValueError(f"unknown API reply message kind {kind}")
