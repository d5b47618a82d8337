"""What the controller answers to each command register: decode the request's parameters, act on the
`ArmMachine`, encode the reply (status byte + parameters).

The first use of each register is logged (so the commands an SDK sends at connect show up), and an
unknown register gets a valid reply flagged invalid (the SDK returns 10) plus a warning, once per
register: a new SDK call shows up in the log instead of hanging the caller.
"""

from __future__ import annotations

import logging
import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..pose import to_xarm
from .codes import FB_MOTION_FINISH, FB_MOTION_START, FB_TRIGGER, Reg, State, reg_name
from .machine import ArmMachine, Refused
from .protocol import (
    PRIVATE_PROTOCOLS,
    PROTOCOL_MODBUS,
    STATUS_INVALID,
    Request,
    floats,
    modbus_reply,
    pack_floats,
    reply,
    s32,
    text,
    u16,
)

log = logging.getLogger("rio_ufactory.emulator")

#: Zero bytes after the status of an unknown register's reply: getters the SDK parses find data.
UNKNOWN_PAD = 64


@dataclass(frozen=True)
class FeedbackTag:
    """Whom to tell that a queued command started / finished: its connection and request."""

    conn: Any
    transaction: int
    protocol: int
    register: int
    kinds: int  # the feedback bits the client asked for when it sent the command


class CommandHandler:
    def __init__(self, machine: ArmMachine):
        self.m = machine
        self._seen: set[int] = set()
        self._table: dict[int, Callable[[bytes, Any, Request], bytes | None]] = {}
        for name in dir(self):
            if name.startswith("_r_"):
                self._table[int(Reg[name[3:].upper()])] = getattr(self, name)

    # -- dispatch --------------------------------------------------------------------------------------
    def handle(self, req: Request, conn: Any) -> bytes | None:
        if req.protocol == PROTOCOL_MODBUS:
            self._first(1000, "plain Modbus TCP request (function %d): answered 'illegal function'",
                        req.params[0] if req.params else -1)
            return modbus_reply(req, bytes([(req.params[0] if req.params else 0) | 0x80, 0x01]))
        if req.protocol not in PRIVATE_PROTOCOLS:
            self._first(1001, "frame with protocol id %d ignored", req.protocol)
            return None
        fn = self._table.get(req.register)
        if fn is None:
            self._first(req.register, "unknown command %s (%d bytes of parameters): answered invalid", reg_name(
                req.register), len(req.params), level=logging.WARNING)
            with self.m.lock:
                return reply(req, self.m.status_byte() | STATUS_INVALID, bytes(UNKNOWN_PAD))
        self._first(req.register, "client uses %s", reg_name(req.register), level=logging.DEBUG)
        with self.m.lock:
            try:
                params = fn(req.params, conn, req) or b""
                status = self.m.status_byte()
            except Refused as e:
                log.info("%s refused: %s", reg_name(req.register), e)
                params, status = b"", self.m.status_byte() | STATUS_INVALID
            except (struct.error, IndexError, ValueError) as e:
                log.info("%s: bad parameters %s (%s)", reg_name(req.register), req.params.hex(" "), e)
                params, status = b"", self.m.status_byte() | STATUS_INVALID
        return reply(req, status, params)

    def _first(self, key: int, msg: str, *args: Any, level: int = logging.INFO) -> None:
        if key not in self._seen:
            self._seen.add(key)
            log.log(level, msg, *args)

    def _tag(self, conn: Any, req: Request) -> FeedbackTag | None:
        kinds = getattr(conn, "feedback_type", 0)
        return FeedbackTag(conn, req.transaction, req.protocol, req.register, kinds) if kinds else None

    @staticmethod
    def _motion_kinds(tag: FeedbackTag | None) -> tuple[int, int]:
        if tag is None:
            return 0, 0
        return tag.kinds & FB_MOTION_START, tag.kinds & FB_MOTION_FINISH

    @staticmethod
    def _checked(p: bytes, nfloats: int) -> int:
        """The only-check byte after `nfloats` floats (0: execute)."""
        return p[4 * nfloats] if len(p) > 4 * nfloats else 0

    # -- identity ----------------------------------------------------------------------------------------
    def _r_get_version(self, p, conn, req):
        return text(self.m.version, 40)

    def _r_get_robot_sn(self, p, conn, req):
        raw = self.m.sn.encode("ascii") + b"\0" + self.m.box_sn.encode("ascii") + b"\0"
        return raw.ljust(40, b"\0")

    def _r_check_verify(self, p, conn, req):
        return bytes([0])

    def _r_get_pwr_version(self, p, conn, req):
        return bytes([1, 0, 0, 0, 0, 0])

    def _r_get_hd_types(self, p, conn, req):
        return bytes([0, 0])

    # -- state, mode, errors ---------------------------------------------------------------------------------
    def _r_motion_en(self, p, conn, req):
        self.m.motion_enable(p[0], bool(p[1]))

    def _r_set_state(self, p, conn, req):
        self.m.set_state(p[0])

    def _r_get_state(self, p, conn, req):
        return bytes([int(self.m.state)])

    def _r_set_mode(self, p, conn, req):
        self.m.set_mode(p[0])

    def _r_get_cmdnum(self, p, conn, req):
        return u16(self.m.motion.pending)

    def _r_get_error(self, p, conn, req):
        return bytes([self.m.error_code & 0xFF, self.m.warn_code & 0xFF])

    def _r_clean_err(self, p, conn, req):
        self.m.clean_error()

    def _r_clean_war(self, p, conn, req):
        self.m.warn_code = 0

    def _r_set_brake(self, p, conn, req):
        pass

    def _r_system_control(self, p, conn, req):
        pass

    def _r_get_movement(self, p, conn, req):
        return bytes([int(self.m.state == State.MOVING)])

    # -- motion --------------------------------------------------------------------------------------------
    def _r_move_servoj(self, p, conn, req):
        self.m.servo_joints(floats(p, 7))

    def _r_move_servo_cart(self, p, conn, req):
        v = floats(p, 9)
        self.m.servo_cartesian(v[:6], tool_coord=bool(v[8]))

    def _r_move_joint(self, p, conn, req):
        v = floats(p, 10)
        if self._checked(p, 10):
            return bytes([0, 0, 0])  # only check: every joint target is fine here
        tag = self._tag(conn, req)
        self.m.move_joints(v[:7], v[7], v[8], tag, self._motion_kinds(tag))

    def _r_move_jointb(self, p, conn, req):
        return self._r_move_joint(p, conn, req)

    def _r_move_home(self, p, conn, req):
        v = floats(p, 3)
        if self._checked(p, 3):
            return bytes([0, 0, 0])
        tag = self._tag(conn, req)
        self.m.move_joints([0.0] * 7, v[0], v[1], tag, self._motion_kinds(tag))  # the controller's home: zero joints

    def _r_move_line(self, p, conn, req):
        # 9 floats (+ only-check, motion type) or, the common form, 10 floats + coord, axis-angle, only-check(, type)
        n = 10 if len(p) in (43, 44) else 9
        v = floats(p, n)
        flags = p[4 * n:]
        coord, axis_angle, check = (flags[0], flags[1], flags[2]) if n == 10 else (0, 0, flags[0] if flags else 0)
        if check:
            return bytes([0, 0, 0])
        tag = self._tag(conn, req)
        self.m.move_line(v[:6], v[6], v[7], tool_coord=bool(coord), axis_angle=bool(axis_angle), tag=tag,
                         kinds=self._motion_kinds(tag))

    def _r_move_lineb(self, p, conn, req):
        v = floats(p, 10)
        if self._checked(p, 10):
            return bytes([0, 0, 0])
        tag = self._tag(conn, req)
        self.m.move_line(v[:6], v[6], v[7], tag=tag, kinds=self._motion_kinds(tag))

    def _r_move_line_tool(self, p, conn, req):
        v = floats(p, 9)
        if self._checked(p, 9):
            return bytes([0, 0, 0])
        tag = self._tag(conn, req)
        self.m.move_line(v[:6], v[6], v[7], tool_coord=True, tag=tag, kinds=self._motion_kinds(tag))

    def _r_sleep_instt(self, p, conn, req):
        tag = self._tag(conn, req)
        self.m.pause_for(floats(p, 1)[0], tag, self._motion_kinds(tag))

    def _r_feedback_check(self, p, conn, req):
        tag = self._tag(conn, req)
        if tag is not None:
            self.m.marker(tag, FB_MOTION_FINISH)

    def _r_set_feedback_type(self, p, conn, req):
        if conn is not None:
            conn.feedback_type = p[0] if p else 0

    # -- kinematics ---------------------------------------------------------------------------------------
    def _r_get_tcp_pose(self, p, conn, req):
        return pack_floats(self.m.snapshot.pose)

    def _r_get_tcp_pose_aa(self, p, conn, req):
        s = self.m.snapshot
        return pack_floats([*s.pose[:3], *s.rotvec])

    def _r_get_joint_pos(self, p, conn, req):
        s = self.m.snapshot
        parts = [s.q, s.qd, s.torque]
        n = max(1, min((p[0] & 0x0F) if p else 1, 3))
        return b"".join(pack_floats(x) for x in parts[:n])

    def _r_get_joint_tau(self, p, conn, req):
        return pack_floats(self.m.snapshot.torque)

    def _r_get_fk(self, p, conn, req):
        q = floats(p, 7)[: self.m.axis]
        if self.m.kin is None:
            raise Refused("no kinematic model")
        return pack_floats(to_xarm(self.m.tcp_frame(q)))

    def _r_get_ik(self, p, conn, req):
        pose = floats(p, 6)
        ref = floats(p, 7, 25)[: self.m.axis] if len(p) >= 25 + 28 else None
        q = self.m.inverse_kinematics(pose, ref)
        out = np.zeros(7)
        out[: self.m.axis] = q
        return pack_floats(out)

    def _r_is_joint_limit(self, p, conn, req):
        q = np.array(floats(p, 7)[: self.m.axis])
        lim = self.m.limits
        return bytes([int(bool(np.any((q < lim[:, 0]) | (q > lim[:, 1]))))])

    def _r_is_tcp_limit(self, p, conn, req):
        return bytes([0])

    # -- parameters ----------------------------------------------------------------------------------------
    def _r_set_tcp_offset(self, p, conn, req):
        self.m.tcp_offset = np.array(floats(p, 6))

    def _r_set_load_param(self, p, conn, req):
        load = np.array(floats(p, 4))
        tag = self._tag(conn, req)

        def apply() -> None:
            self.m.tcp_load = load

        if tag is not None and tag.kinds & FB_TRIGGER:
            self.m.marker(tag, FB_TRIGGER, on_reach=apply)
        else:
            apply()

    def _r_set_collis_sens(self, p, conn, req):
        if not 0 <= p[0] <= 5:
            raise Refused("collision sensitivity is 0..5")
        self.m.collision_sens = p[0]

    def _r_set_teach_sens(self, p, conn, req):
        if not 1 <= p[0] <= 5:
            raise Refused("teach sensitivity is 1..5")
        self.m.teach_sens = p[0]

    def _r_set_gravity_dir(self, p, conn, req):
        self.m.gravity = np.array(floats(p, 3))

    def _r_set_world_offset(self, p, conn, req):
        self.m.world_offset = np.array(floats(p, 6))

    def _r_set_simulation_robot(self, p, conn, req):
        self.m.simulation_robot = bool(p[0])

    def _r_cnter_reset(self, p, conn, req):
        self.m.counter = 0

    def _r_cnter_plus(self, p, conn, req):
        self.m.counter += 1

    # handlers that only remember a setting (and read it back), built while the class body runs
    def _store(name: str, fmt: str = "f") -> Callable:
        def handler(self, p, conn, req):
            self.m.params[name] = floats(p, 1)[0] if fmt == "f" else p[0]
        return handler

    def _load(name: str, default: int = 0) -> Callable:
        def handler(self, p, conn, req):
            return bytes([int(self.m.params.get(name, default)) & 0xFF])
        return handler

    _r_set_tcp_jerk = _store("tcp_jerk")
    _r_set_tcp_maxacc = _store("tcp_maxacc")
    _r_set_joint_jerk = _store("joint_jerk")
    _r_set_joint_maxacc = _store("joint_maxacc")
    _r_set_reduced_trsv = _store("reduced_tcp_speed")
    _r_set_reduced_p2pv = _store("reduced_joint_speed")
    _r_set_reduced_mode = _store("reduced_mode", "b")
    _r_get_reduced_mode = _load("reduced_mode")
    _r_set_fense_on = _store("fence", "b")
    _r_set_collis_reb = _store("collision_rebound", "b")
    _r_set_safe_level = _store("safe_level", "b")
    _r_get_safe_level = _load("safe_level", 4)
    _r_set_allow_approx_motion = _store("approx_motion", "b")
    _r_get_allow_approx_motion = _load("approx_motion")
    _r_report_tau_or_i = _store("tau_or_i", "b")
    _r_get_report_tau_or_i = _load("tau_or_i")
    _r_set_self_collis_check = _store("self_collision", "b")
    _r_set_collis_tool = _store("collision_tool", "b")
    _r_set_cartv_continue = _store("cart_continuous", "b")
    _r_set_io_stop_reset = _store("io_stop_reset", "b")
    del _store, _load

    def _r_set_limit_xyz(self, p, conn, req):
        pass

    def _r_set_reduced_jrange(self, p, conn, req):
        pass

    def _r_get_reduced_state(self, p, conn, req):
        m = self.m.params
        return (bytes([int(m.get("reduced_mode", 0))]) + struct.pack(">6h", 9999, -9999, 9999, -9999, 9999, -9999)
                + pack_floats([m.get("reduced_tcp_speed", 0.0), m.get("reduced_joint_speed", 0.0)])
                + pack_floats(self.m.snapshot.limits)
                + bytes([int(m.get("fence", 0)), int(m.get("collision_rebound", 0))]))

    def _r_reload_dynamics(self, p, conn, req):
        pass

    def _r_clean_conf(self, p, conn, req):
        pass

    def _r_save_conf(self, p, conn, req):
        pass

    # -- tool board: GPIO, registers, RS-485 ---------------------------------------------------------------
    def _r_tgpio_w16b(self, p, conn, req):
        bid, addr = p[0], struct.unpack_from(">H", p, 1)[0]
        if not self.m.tool.write(bid, addr, floats(p, 1, 3)[0]):
            raise Refused(f"tool register 0x{addr:04X} of device {bid} cannot be written")

    def _r_tgpio_w32b(self, p, conn, req):
        bid, addr = p[0], struct.unpack_from(">H", p, 1)[0]
        if not self.m.tool.write(bid, addr, floats(p, 1, 3)[0], wide=True):
            raise Refused(f"tool register 0x{addr:04X} of device {bid} cannot be written")

    def _read_tool(self, p, wide: bool) -> bytes:
        bid, addr = p[0], struct.unpack_from(">H", p, 1)[0]
        value = self.m.tool.read(bid, addr, wide)
        if value is None:
            raise Refused(f"no tool register 0x{addr:04X} on device {bid}")
        return s32(value)

    def _r_tgpio_r16b(self, p, conn, req):
        return self._read_tool(p, False)

    def _r_tgpio_r32b(self, p, conn, req):
        return self._read_tool(p, True)

    def _r_tgpio_err(self, p, conn, req):
        return bytes([self.m.tool.device_error() & 0xFF, 0])

    def _r_rs485_rtu(self, p, conn, req):
        host = p[0]
        answer = self.m.tool.relay(p[1:]) if host == 9 else None
        if answer is None:
            raise Refused(f"no answer on RS-485 host {host} to {p[1:].hex(' ')}")
        return bytes([host]) + answer

    def _r_tgpio_mb_tiout(self, p, conn, req):
        pass

    def _r_tgpio_com_tiout(self, p, conn, req):
        pass

    def _r_delayed_tgpio_set(self, p, conn, req):
        self.m.tool.set_output_later(p[0], bool(p[1]), floats(p, 1, 2)[0])

    # -- control box GPIO (nothing wired) --------------------------------------------------------------------
    def _r_cgpio_get_digit(self, p, conn, req):
        return u16(0)

    def _r_cgpio_get_analog1(self, p, conn, req):
        return u16(0)

    def _r_cgpio_get_analog2(self, p, conn, req):
        return u16(0)

    def _r_cgpio_set_digit(self, p, conn, req):
        pass

    def _r_cgpio_get_state(self, p, conn, req):
        return bytes([0, 0]) + struct.pack(">8H", 0xFFFF, 0xFFFF, 0, 0, 0, 0, 0, 0) + bytes(32)
