"""What the WebXR page may send, checked before anything reaches the robot.

Every WebSocket message is one JSON object of at most `MAX_BYTES` (a `hands` message: at most
`MAX_HANDS_BYTES`; a WebSocket frame over that closes the connection), with exactly the keys of its
type, each of the right type; numbers must be finite (JSON's NaN/Infinity extensions are refused while
parsing, and an overflowing literal like 1e999 is refused after) and within bounds (positions within
`MAX_POS_M` of the reference space origin, a quaternion of about unit norm, trigger 0..1). A message
that fails any check raises `ProtocolError` and changes nothing: the server counts it, answers with
an error and, after `MAX_ERRORS` of them, closes the connection.

Page -> node:
    {"type": "hello", "client": str}                              once, after connecting
    {"type": "input", "seq": int, "t": ms, "source": str,         a controller/hand/phone sample
     "pose": {"p": [x, y, z], "q": [x, y, z, w]} | null,          (WebXR reference space, meters)
     "clutch": bool, "trigger": 0..1, "mode": bool, "done": bool}
    {"type": "hands", "seq": int, "t": ms,                        both tracked hands, one XR frame
     "left": HAND | null, "right": HAND | null}                   (null: that hand is not tracked)
        HAND = {"j": [[x, y, z] * 25], "q": [x, y, z, w]}
    {"type": "ping", "id": int, "t": ms}                          round-trip probe

`hands` (sent by the page when the node's config says `"hands": true`, at most `hands_hz` a second):
`j` is the hand's 25 joint positions in `rio.interfaces.teleop.HAND_JOINTS` order (WebXR's XRHand
order, "wrist" first), meters in the session's reference space (y up, -z forward), rounded by the
page to 0.1 mm; `q` is the wrist joint's orientation in that space (x, y, z, w, rounded to 1e-5;
WebXR's joint axes: -z along the hand away from the wrist, -y perpendicular to the skin into the
palm). Checks: exactly these keys, exactly 25 joints of 3 finite numbers each, every position within
`MAX_POS_M` of the origin and every joint within `MAX_HAND_SPAN_M` of the wrist, `q` of about unit
norm (normalised here). Two hands rounded as the page rounds them take about 1.3 kB;
`MAX_HANDS_BYTES` leaves room for unrounded doubles (about 3.4 kB).

Node -> page:
    {"type": "config", ...}, {"type": "pong", "id", "t", "server_t"}, {"type": "status", ...},
    {"type": "error", "message": str}
"""

from __future__ import annotations

import json
import math
from typing import Any

MAX_BYTES = 2048
MAX_HANDS_BYTES = 8192
MAX_POS_M = 20.0
MAX_HAND_SPAN_M = 0.5
N_JOINTS = 25  # len(rio.interfaces.teleop.HAND_JOINTS): WebXR's XRHand
MAX_ERRORS = 50
SOURCES = ("xr-controller", "xr-hand", "xr-viewer", "orientation", "buttons", "test")


class ProtocolError(ValueError):
    pass


def _no_constants(name: str) -> Any:
    raise ProtocolError(f"{name} is not a number this page may send")


def parse(raw: str | bytes) -> dict[str, Any]:
    """One validated message (see the module docstring) or ProtocolError saying what is wrong."""
    if isinstance(raw, bytes | bytearray):
        raise ProtocolError("binary frames are not accepted")
    if len(raw) > MAX_HANDS_BYTES:  # a character is at least one byte
        raise ProtocolError(f"message of {len(raw)} characters (limit {MAX_HANDS_BYTES} bytes)")
    size = len(raw.encode("utf-8", errors="replace"))
    if size > MAX_HANDS_BYTES:
        raise ProtocolError(f"message over {MAX_HANDS_BYTES} bytes")
    try:
        msg = json.loads(raw, parse_constant=_no_constants)
    except ProtocolError:
        raise
    except (ValueError, RecursionError) as e:
        raise ProtocolError(f"not JSON: {e}") from None
    if not isinstance(msg, dict):
        raise ProtocolError("a message is a JSON object")
    kind = msg.get("type")
    if size > MAX_BYTES and kind != "hands":
        raise ProtocolError(f"message of {size} bytes over {MAX_BYTES} bytes (the limit of every message "
                            f"but hands)")
    if kind == "input":
        return _input(msg)
    if kind == "hands":
        return _hands(msg)
    if kind == "ping":
        _keys(msg, {"type", "id", "t"})
        return {"type": "ping", "id": _int(msg, "id"), "t": _num(msg, "t", 1e13)}
    if kind == "hello":
        _keys(msg, {"type", "client"})
        client = msg["client"]
        if not isinstance(client, str) or len(client) > 256:
            raise ProtocolError("hello.client: a string of at most 256 characters")
        return {"type": "hello", "client": client}
    raise ProtocolError(f"unknown message type {str(kind)[:32]!r}")


def _keys(msg: dict, keys: set[str]) -> None:
    if set(msg) != keys:
        extra, missing = sorted(set(msg) - keys), sorted(keys - set(msg))
        why = [f"unknown keys {[k[:32] for k in extra]}"] if extra else []
        why += [f"missing {missing}"] if missing else []
        raise ProtocolError(f"{msg.get('type')}: " + "; ".join(why))


def _num(msg: dict, key: str, bound: float, lo: float | None = None) -> float:
    v = msg[key]
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise ProtocolError(f"{key}: a number, not {type(v).__name__}")
    v = float(v)
    if not math.isfinite(v):
        raise ProtocolError(f"{key}: not finite")
    if not (-bound if lo is None else lo) <= v <= bound:
        raise ProtocolError(f"{key}: {v:g} is out of range")
    return v


def _int(msg: dict, key: str) -> int:
    v = msg[key]
    if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v < 2**53:
        raise ProtocolError(f"{key}: a non-negative integer")
    return v


def _bool(msg: dict, key: str) -> bool:
    v = msg[key]
    if not isinstance(v, bool):
        raise ProtocolError(f"{key}: true or false")
    return v


def _vec(v: Any, n: int, what: str, bound: float) -> list[float]:
    if not isinstance(v, list) or len(v) != n:
        raise ProtocolError(f"{what}: a list of {n} numbers")
    out = []
    for i, x in enumerate(v):
        if isinstance(x, bool) or not isinstance(x, int | float) or not math.isfinite(float(x)):
            raise ProtocolError(f"{what}[{i}]: not a finite number")
        if abs(float(x)) > bound:
            raise ProtocolError(f"{what}[{i}]: {float(x):g} is out of range (|x| <= {bound:g})")
        out.append(float(x))
    return out


def _input(msg: dict) -> dict[str, Any]:
    _keys(msg, {"type", "seq", "t", "source", "pose", "clutch", "trigger", "mode", "done"})
    source = msg["source"]
    if source not in SOURCES:
        raise ProtocolError(f"source: one of {list(SOURCES)}")
    pose = msg["pose"]
    if pose is not None:
        if not isinstance(pose, dict) or set(pose) != {"p", "q"}:
            raise ProtocolError("pose: null or {\"p\": [x, y, z], \"q\": [x, y, z, w]}")
        pose = {"p": _vec(pose["p"], 3, "pose.p", MAX_POS_M), "q": _quat(pose["q"], "pose.q")}
    return {"type": "input", "seq": _int(msg, "seq"), "t": _num(msg, "t", 1e13), "source": source, "pose": pose,
            "clutch": _bool(msg, "clutch"), "trigger": _num(msg, "trigger", 1.0, lo=0.0),
            "mode": _bool(msg, "mode"), "done": _bool(msg, "done")}


def _quat(v: Any, what: str) -> list[float]:
    """[x, y, z, w] of about unit norm, normalised."""
    q = _vec(v, 4, what, 1.5)
    norm = math.sqrt(sum(x * x for x in q))
    if not 0.5 < norm < 1.5:
        raise ProtocolError(f"{what}: not a rotation (norm {norm:.3g})")
    return [x / norm for x in q]


def _hand(v: Any, side: str) -> dict[str, Any] | None:
    if v is None:
        return None
    if not isinstance(v, dict) or set(v) != {"j", "q"}:
        raise ProtocolError(f"{side}: null or {{\"j\": [[x, y, z] * {N_JOINTS}], \"q\": [x, y, z, w]}}")
    joints = v["j"]
    if not isinstance(joints, list) or len(joints) != N_JOINTS:
        raise ProtocolError(f"{side}.j: a list of {N_JOINTS} joints (WebXR XRHand order), "
                            f"not {len(joints) if isinstance(joints, list) else type(joints).__name__}")
    j = [_vec(p, 3, f"{side}.j[{i}]", MAX_POS_M) for i, p in enumerate(joints)]
    w = j[0]
    for i, p in enumerate(j[1:], 1):
        if math.dist(p, w) > MAX_HAND_SPAN_M:
            raise ProtocolError(f"{side}.j[{i}]: {math.dist(p, w):.3g} m from the wrist (a hand is at most "
                                f"{MAX_HAND_SPAN_M:g} m)")
    return {"j": j, "q": _quat(v["q"], f"{side}.q")}


def _hands(msg: dict) -> dict[str, Any]:
    _keys(msg, {"type", "seq", "t", "left", "right"})
    return {"type": "hands", "seq": _int(msg, "seq"), "t": _num(msg, "t", 1e13),
            "left": _hand(msg["left"], "left"), "right": _hand(msg["right"], "right")}
