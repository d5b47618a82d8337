"""openpi's wire format, written from its protocol (openpi-client's `msgpack_numpy`):

- a message is one msgpack document; numpy arrays travel as maps
  `{b"__ndarray__": True, b"data": <raw bytes>, b"dtype": <numpy dtype str>, b"shape": [..]}` and numpy
  scalars as `{b"__npgeneric__": True, b"data": <python value>, b"dtype": <str>}` (keys are msgpack
  *bin*, i.e. Python bytes); object, void and complex dtypes are refused;
- on connecting, the server first sends one such message with its metadata; then each observation
  sent gets one reply with the actions (`{"actions": [H, D], ...}`), and a server-side failure comes
  back as a text frame holding the traceback.

Decoding builds arrays from dtype strings and raw bytes only: nothing can execute code.
"""

from __future__ import annotations

from typing import Any

import msgpack
import numpy as np

_ARRAY, _SCALAR = b"__ndarray__", b"__npgeneric__"


def _encode(obj: Any) -> Any:
    if isinstance(obj, (np.ndarray, np.generic)) and obj.dtype.kind in "VOc":
        raise ValueError(f"openpi cannot carry numpy dtype {obj.dtype}")
    if isinstance(obj, np.ndarray):
        arr = np.ascontiguousarray(obj)
        return {_ARRAY: True, b"data": arr.tobytes(), b"dtype": arr.dtype.str, b"shape": list(arr.shape)}
    if isinstance(obj, np.generic):
        return {_SCALAR: True, b"data": obj.item(), b"dtype": obj.dtype.str}
    raise TypeError(f"cannot send {type(obj).__name__} to an openpi server")


def _decode(obj: dict) -> Any:
    if _ARRAY in obj:
        dtype = np.dtype(obj[b"dtype"])
        if dtype.kind in "VOc":
            raise ValueError(f"refusing numpy dtype {dtype} from the server")
        return np.frombuffer(obj[b"data"], dtype=dtype).reshape(obj[b"shape"])
    if _SCALAR in obj:
        return np.dtype(obj[b"dtype"]).type(obj[b"data"])
    return obj


def packb(obj: Any) -> bytes:
    return msgpack.packb(obj, default=_encode)


def unpackb(data: bytes) -> Any:
    return msgpack.unpackb(data, object_hook=_decode)
