"""Isaac-GR00T's inference-service wire format, written from its protocol (`gr00t/eval/service.py`
for N1.5, `gr00t/policy/server_client.py` for N1.6):

- ZMQ REQ/REP; each request is one msgpack map `{"endpoint": name, "data": ..., "api_token": ...}`
  (`data` absent for endpoints without input: `ping`, `kill`, `get_modality_config`);
- numpy arrays travel as `{"__ndarray_class__": True, "as_npy": <bytes of a .npy file>}`, written and
  read with `allow_pickle=False` (text keys here, unlike openpi's bytes keys);
- a failure comes back as `{"error": "<message>"}`.
"""

from __future__ import annotations

import io
from typing import Any

import msgpack
import numpy as np

_TAG = "__ndarray_class__"


def _encode(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        obj = np.asarray(obj)
    if isinstance(obj, np.ndarray):
        buf = io.BytesIO()
        np.save(buf, obj, allow_pickle=False)
        return {_TAG: True, "as_npy": buf.getvalue()}
    raise TypeError(f"cannot send {type(obj).__name__} to a GR00T server")


def _decode(obj: dict) -> Any:
    if _TAG in obj:
        return np.load(io.BytesIO(obj["as_npy"]), allow_pickle=False)
    return obj


def packb(obj: Any) -> bytes:
    return msgpack.packb(obj, default=_encode)


def unpackb(data: bytes) -> Any:
    return msgpack.unpackb(data, object_hook=_decode)


def request(endpoint: str, data: Any = None, api_token: str | None = None, with_data: bool = True) -> bytes:
    msg: dict[str, Any] = {"endpoint": endpoint}
    if with_data:
        msg["data"] = data
    if api_token:
        msg["api_token"] = api_token
    return packb(msg)
