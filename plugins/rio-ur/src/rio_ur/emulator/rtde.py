"""The controller's RTDE server (TCP 30004), protocol version 2 as UR's RTDE guide documents it, enough
for ur-rtde's `RTDEReceiveInterface` (and any RTDE client) to read an emulated arm.

Every package: uint16 size (header included), uint8 type, payload, big-endian.
- 'V' request protocol version (uint16) -> uint8 accepted (1 for version 2, 0 otherwise);
- 'v' get URControl version -> uint32 major, minor, bugfix, build;
- 'O' setup outputs: double frequency, comma-separated names -> uint8 recipe id, comma-separated types
  ("NOT_FOUND" for a name the emulator does not serve: the client refuses the recipe);
- 'I' setup inputs -> uint8 recipe id, types (input registers are accepted, their values ignored);
- 'S' start / 'P' pause -> uint8 accepted; once started, 'U' data packages (uint8 recipe id, then the
  values) stream at the recipe's frequency (at most 500 Hz, the controller's rate);
- 'U' from the client (input recipe data) is read and dropped.
"""

from __future__ import annotations

import select
import socket
import struct
import time
from collections.abc import Callable
from typing import Any

from rio.emulation import TcpDevice

from .robot import PLAYING, STOPPED, URRobot

VERSION = (5, 15, 0, 0)
_FMT = {"BOOL": "?", "UINT8": "B", "UINT32": "I", "UINT64": "Q", "INT32": "i", "DOUBLE": "d",
        "VECTOR3D": "3d", "VECTOR6D": "6d", "VECTOR6INT32": "6i", "VECTOR6UINT32": "6I"}
Z6, Z3 = (0.0,) * 6, (0.0,) * 3


def _outputs(r: URRobot, t0: float) -> dict[str, tuple[str, Callable[[], Any]]]:
    """Every output the emulator serves: name -> (RTDE type, value now)."""
    q = lambda: tuple(r.q)  # noqa: E731
    out: dict[str, tuple[str, Callable[[], Any]]] = {
        "timestamp": ("DOUBLE", lambda: time.monotonic() - t0),
        "target_q": ("VECTOR6D", lambda: tuple(r.q_cmd)),
        "target_qd": ("VECTOR6D", lambda: tuple(r.qd)),
        "target_qdd": ("VECTOR6D", lambda: Z6),
        "target_current": ("VECTOR6D", lambda: Z6),
        "target_moment": ("VECTOR6D", lambda: Z6),
        "actual_q": ("VECTOR6D", q),
        "actual_qd": ("VECTOR6D", lambda: tuple(r.qd)),
        "actual_current": ("VECTOR6D", lambda: Z6),
        "joint_control_output": ("VECTOR6D", lambda: Z6),
        "actual_TCP_pose": ("VECTOR6D", lambda: tuple(r.tcp_pose())),
        "actual_TCP_speed": ("VECTOR6D", lambda: Z6),
        "actual_TCP_force": ("VECTOR6D", lambda: Z6),
        "target_TCP_pose": ("VECTOR6D", lambda: tuple(r.tcp_pose())),
        "target_TCP_speed": ("VECTOR6D", lambda: Z6),
        "actual_digital_input_bits": ("UINT64", lambda: 0),
        "actual_digital_output_bits": ("UINT64", lambda: 0),
        "joint_temperatures": ("VECTOR6D", lambda: (30.0,) * 6),
        "actual_execution_time": ("DOUBLE", lambda: 0.2),
        "robot_mode": ("INT32", lambda: r.robot_mode),
        "joint_mode": ("VECTOR6INT32", lambda: (253,) * 6),
        "safety_mode": ("INT32", lambda: r.safety_mode),
        "safety_status": ("INT32", lambda: r.safety_mode),
        "actual_tool_accelerometer": ("VECTOR3D", lambda: (0.0, 0.0, 9.81)),
        "speed_scaling": ("DOUBLE", lambda: r.speed_slider),
        "target_speed_fraction": ("DOUBLE", lambda: r.speed_slider),
        "actual_momentum": ("DOUBLE", lambda: 0.0),
        "actual_main_voltage": ("DOUBLE", lambda: 48.0),
        "actual_robot_voltage": ("DOUBLE", lambda: 48.0),
        "actual_robot_current": ("DOUBLE", lambda: 0.5),
        "actual_joint_voltage": ("VECTOR6D", lambda: (48.0,) * 6),
        "runtime_state": ("UINT32", lambda: PLAYING if r.running else STOPPED),
        "robot_status_bits": ("UINT32", lambda: r.robot_status_bits()),
        "safety_status_bits": ("UINT32", lambda: r.safety_status_bits()),
        "standard_analog_input0": ("DOUBLE", lambda: 0.0),
        "standard_analog_input1": ("DOUBLE", lambda: 0.0),
        "standard_analog_output0": ("DOUBLE", lambda: 0.0),
        "standard_analog_output1": ("DOUBLE", lambda: 0.0),
        "output_bit_registers0_to_31": ("UINT32", lambda: 0),
        "output_bit_registers32_to_63": ("UINT32", lambda: 0),
        "payload": ("DOUBLE", lambda: 0.0),
        "payload_cog": ("VECTOR3D", lambda: Z3),
        "payload_inertia": ("VECTOR6D", lambda: Z6),
        "ft_raw_wrench": ("VECTOR6D", lambda: Z6),
        "tcp_offset": ("VECTOR6D", lambda: Z6),
        "elbow_position": ("VECTOR3D", lambda: Z3),
    }
    for i in range(48):
        out[f"output_int_register_{i}"] = ("INT32", lambda: 0)
        out[f"output_double_register_{i}"] = ("DOUBLE", lambda: 0.0)
    return out


def _input_type(name: str) -> str:
    if name.startswith("input_int_register_"):
        return "INT32"
    if name.startswith("input_double_register_"):
        return "DOUBLE"
    if name.startswith("input_bit_register"):
        return "BOOL"
    if name.endswith("_mask") or name.startswith("standard_digital_output") or name.startswith("tool_digital"):
        return "UINT8"
    if name in ("speed_slider_fraction", "standard_analog_output_0", "standard_analog_output_1"):
        return "DOUBLE"
    if name == "speed_slider_mask":
        return "UINT32"
    return "NOT_FOUND"


def package(kind: bytes, payload: bytes = b"") -> bytes:
    return struct.pack(">HB", 3 + len(payload), kind[0]) + payload


class RtdeServer(TcpDevice):
    def __init__(self, robot: URRobot, host: str, port: int = 30004):
        super().__init__(host, port)
        self.robot = robot
        self.t0 = time.monotonic()
        self.outputs = _outputs(robot, self.t0)
        self.packages_sent = 0

    def serve(self, conn: socket.socket, addr: Any) -> None:
        buf = b""
        recipes: list[tuple[int, float, list[str], str]] = []  # (id, frequency, names, struct format)
        recipe_ids = iter(range(1, 256))
        started, t_next = False, 0.0
        while not self._stop.is_set():
            wait = max(0.0, t_next - time.monotonic()) if started and recipes else 0.2
            ready, _, _ = select.select([conn], [], [], wait)
            if ready:
                data = conn.recv(65536)
                if not data:
                    return
                buf += data
                while len(buf) >= 3:
                    size, kind = struct.unpack(">HB", buf[:3])
                    if len(buf) < size:
                        break
                    body, buf = buf[3:size], buf[size:]
                    reply, started_now = self._answer(chr(kind), body, recipes, recipe_ids, started)
                    if started_now is not None:
                        started = started_now
                        t_next = time.monotonic()
                    if reply:
                        conn.sendall(reply)
            if started and recipes and time.monotonic() >= t_next:
                rid, hz, names, fmt = recipes[-1]
                values: list[Any] = []
                with self.robot.lock:
                    for n in names:
                        v = self.outputs[n][1]()
                        values.extend(v if isinstance(v, tuple) else (v,))
                conn.sendall(package(b"U", struct.pack(fmt, rid, *values)))
                self.packages_sent += 1
                t_next += 1.0 / min(max(hz, 1.0), 500.0)
                if t_next < time.monotonic() - 0.1:
                    t_next = time.monotonic()  # fell behind (a loaded machine): no burst

    def _answer(self, kind: str, body: bytes, recipes: list, ids, started: bool) -> tuple[bytes | None, bool | None]:
        if kind == "V":
            (version,) = struct.unpack(">H", body[:2])
            return package(b"V", struct.pack(">B", int(version == 2))), None
        if kind == "v":
            return package(b"v", struct.pack(">IIII", *VERSION)), None
        if kind == "O":
            (hz,) = struct.unpack(">d", body[:8])
            names = [n for n in body[8:].decode("ascii").split(",") if n]
            types = [self.outputs[n][0] if n in self.outputs else "NOT_FOUND" for n in names]
            if "NOT_FOUND" in types:
                return package(b"O", b"\x00" + ",".join(types).encode()), None
            rid = next(ids)
            fmt = ">B" + "".join(_FMT[t] for t in types)
            recipes.append((rid, hz, names, fmt))
            return package(b"O", struct.pack(">B", rid) + ",".join(types).encode()), None
        if kind == "I":
            names = [n for n in body.decode("ascii").split(",") if n]
            types = [_input_type(n) for n in names]
            rid = 0 if "NOT_FOUND" in types else next(ids)
            return package(b"I", struct.pack(">B", rid) + ",".join(types).encode()), None
        if kind == "S":
            return package(b"S", b"\x01"), bool(recipes)
        if kind == "P":
            return package(b"P", b"\x01"), False
        if kind == "U":
            return None, None  # input data: accepted, not used
        return package(b"M", b""), None
