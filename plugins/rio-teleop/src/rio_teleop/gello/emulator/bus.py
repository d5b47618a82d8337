"""`DynamixelBusEmulator`: XL330 servos answering Dynamixel Protocol 2.0 on a pseudo-terminal.

The driver opens the pty's slave path through the unmodified dynamixel-sdk (`PortHandler`,
`PacketHandler(2.0)`, `GroupSyncRead`, `GroupBulkRead`) and sees what a U2D2 would give it: status
packets with CRC16 and byte stuffing, silence from an id nobody has, Sync/Bulk Read answered one servo
after the other in the order asked. Packets with a bad CRC are ignored, as a servo ignores them.
Handled: PING, READ, WRITE, REG_WRITE/ACTION, REBOOT, SYNC READ, SYNC WRITE, BULK READ, BULK WRITE;
anything else gets an instruction error. Fast Sync/Bulk Read are not emulated (the SDK times out).

The pty's lifecycle is core's `rio.emulation.PtyDevice`; this class is the protocol.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Iterable
from typing import Any

from rio.emulation import PtyDevice

from .. import protocol as P
from .servo import XL330Emulator

log = logging.getLogger("rio_teleop.gello.emulator")


class DynamixelBusEmulator(PtyDevice):
    thread_name = "rio-dynamixel-emulator"

    def __init__(self, ids: Iterable[int] = range(1, 9), *, start: bool = True, **servo_options: Any):
        self.servos: dict[int, XL330Emulator] = {int(i): XL330Emulator(int(i), **servo_options) for i in ids}
        self.stats: Counter[str] = Counter()
        self._parser = P.Parser()
        self._registered: dict[int, tuple[int, bytes]] = {}
        super().__init__(start=start)

    def __repr__(self) -> str:
        return f"<DynamixelBusEmulator {self.port} ids={sorted(self.servos)}>"

    def servo(self, servo_id: int) -> XL330Emulator:
        return self.servos[int(servo_id)]

    # -- serving (under `lock`) -------------------------------------------------------------------
    def on_data(self, data: bytes) -> bytes:
        out = bytearray()
        for sid, inst, params in self._parser.feed(data):
            self.stats[f"inst_{inst:#04x}"] += 1
            try:
                out += self._handle(sid, inst, params)
            except Exception:  # an emulator bug must look like a silent servo, not stop the other packets
                log.exception("emulated Dynamixel bus %s: cannot handle id %d instruction %#x", self.port, sid, inst)
                self.stats["emulator_error"] += 1
        self.stats["bad_crc"] = self._parser.bad_crc
        return bytes(out)

    def _live(self, sid: int) -> XL330Emulator | None:
        s = self.servos.get(sid)
        return s if s is not None and s.responsive else None

    def _reply(self, servo: XL330Emulator, error: int = 0, params: bytes = b"", *, is_read: bool = False) -> bytes:
        level = servo.mem[68]  # Status Return Level: 0 ping only, 1 + reads, 2 all
        if level == 0 or (level == 1 and not is_read):
            return b""
        self.stats["status"] += 1
        return P.status(servo.id, error, params)

    def _handle(self, sid: int, inst: int, params: bytes) -> bytes:
        if sid == P.BROADCAST_ID:
            return self._broadcast(inst, params)
        servo = self._live(sid)
        if servo is None:
            return b""
        if inst == P.PING:
            self.stats["status"] += 1
            return P.status(sid, 0, servo.mem[0:2] + servo.mem[6:7])
        if inst == P.READ and len(params) == 4:
            err, data = servo.read(P.u16(params), P.u16(params, 2))
            return self._reply(servo, err, data, is_read=True)
        if inst in (P.WRITE, P.REG_WRITE) and len(params) >= 3:
            if inst == P.REG_WRITE:
                self._registered[sid] = (P.u16(params), params[2:])
                return self._reply(servo)
            return self._reply(servo, servo.write(P.u16(params), params[2:]))
        if inst == P.ACTION:
            self._action(sid)
            return self._reply(servo)
        if inst == P.REBOOT:
            servo.mem[64] = 0
            return self._reply(servo)
        self.stats["unknown_instruction"] += 1
        return self._reply(servo, P.ERR_INSTRUCTION)

    def _action(self, sid: int | None = None) -> None:
        for i in [sid] if sid is not None else list(self._registered):
            if i in self._registered:
                address, data = self._registered.pop(i)
                self.servos[i].write(address, data)

    def _broadcast(self, inst: int, params: bytes) -> bytes:
        out = bytearray()
        if inst == P.PING:
            for sid in sorted(self.servos):
                s = self._live(sid)
                if s is not None:
                    out += P.status(sid, 0, s.mem[0:2] + s.mem[6:7])
        elif inst == P.SYNC_READ and len(params) >= 5:
            address, length = P.u16(params), P.u16(params, 2)
            for sid in params[4:]:
                s = self._live(sid)
                if s is not None:
                    err, data = s.read(address, length)
                    out += P.status(sid, err, data)
        elif inst == P.SYNC_WRITE and len(params) >= 4:
            address, length = P.u16(params), P.u16(params, 2)
            body = params[4:]
            for k in range(0, len(body) - length, length + 1):
                s = self._live(body[k])
                if s is not None:
                    s.write(address, body[k + 1:k + 1 + length])
        elif inst == P.BULK_READ:
            for k in range(0, len(params) - 4, 5):
                s = self._live(params[k])
                if s is not None:
                    err, data = s.read(P.u16(params, k + 1), P.u16(params, k + 3))
                    out += P.status(s.id, err, data)
        elif inst == P.BULK_WRITE:
            k = 0
            while k + 5 <= len(params):
                sid, address, length = params[k], P.u16(params, k + 1), P.u16(params, k + 3)
                s = self._live(sid)
                if s is not None:
                    s.write(address, params[k + 5:k + 5 + length])
                k += 5 + length
        elif inst == P.ACTION:
            self._action()
        elif inst == P.WRITE and len(params) >= 3:
            for s in self.servos.values():
                s.write(P.u16(params), params[2:])
        else:
            self.stats["unknown_instruction"] += 1
        if out:
            self.stats["status"] += 1
        return bytes(out)
