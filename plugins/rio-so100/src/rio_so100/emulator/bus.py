"""`FeetechBusEmulator`: STS3215 servos answering the Feetech protocol on a pseudo-terminal.

The driver (through `scservo_sdk`, unmodified) opens the pty's slave path as its serial port and
sees exactly the bytes a real bus would send: status packets with checksums and error bits, silence
from an id nobody has, SYNC READ answers one servo after the other. Instruction packets with a bad
checksum are ignored, as a servo ignores them. For tests, `corrupt_replies()` damages the checksum
of the next status packets and `STS3215Emulator.responsive = False` silences a servo.

The pty's lifecycle is core's `rio.emulation.PtyDevice` (one thread serves the master side; the slave
stays open, so a driver may close and reopen the port while the bus lives); this class is the protocol.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Iterable
from typing import Any

from rio.emulation import PtyDevice

from ..feetech import protocol as P
from .servo import STS3215Emulator

SO_ARM_IDS = (1, 2, 3, 4, 5, 6)
log = logging.getLogger("rio_so100.emulator")


class FeetechBusEmulator(PtyDevice):
    """`lock` (the device's) is taken while a packet is handled: hold it to change servos consistently
    from another thread. `start=False`: add or replace servos, then `start()`."""

    thread_name = "rio-feetech-emulator"

    def __init__(self, ids: Iterable[int] = SO_ARM_IDS, *, start: bool = True, **servo_options: Any):
        self.servos: dict[int, STS3215Emulator] = {int(i): STS3215Emulator(int(i), **servo_options) for i in ids}
        self.stats: Counter[str] = Counter()
        self._corrupt: list[int | None] = []
        self._buf = bytearray()
        super().__init__(start=start)

    def __repr__(self) -> str:
        return f"<FeetechBusEmulator {self.port} ids={sorted(self.servos)}>"

    # -- test and demo controls ----------------------------------------------------------------------
    def servo(self, servo_id: int) -> STS3215Emulator:
        return self.servos[int(servo_id)]

    def corrupt_replies(self, count: int = 1, servo_id: int | None = None) -> None:
        """Damage the checksum of the next `count` status packets (of `servo_id` only, if given)."""
        with self.lock:
            self._corrupt.extend([servo_id] * int(count))

    def positions(self) -> dict[int, float]:
        """Present position (register frame, steps) of every servo, brought up to now."""
        with self.lock:
            for s in self.servos.values():
                s.update()
            return {i: s.present() for i, s in self.servos.items()}

    # -- serving (under `lock`) -----------------------------------------------------------------------
    def on_data(self, data: bytes) -> bytes:
        self._buf += data
        replies = bytearray()
        for pkt in self._packets():
            try:
                replies += self._handle(pkt)
            except Exception:  # an emulator bug must look like a silent servo, not stop the other packets
                log.exception("emulated bus %s: cannot handle packet %s", self.port, pkt.hex(" "))
                self.stats["emulator_error"] += 1
        return bytes(replies)

    def _packets(self):
        """Complete, checksum-valid instruction packets from the input buffer."""
        buf = self._buf
        while True:
            start = buf.find(P.HEADER)
            if start < 0:
                del buf[:max(len(buf) - 1, 0)]  # keep a trailing 0xFF: it may start a header
                return
            del buf[:start]
            if len(buf) < 4:
                return
            total = buf[3] + 4
            if buf[3] < 2:
                del buf[:1]
                self.stats["bad_length"] += 1
                continue
            if len(buf) < total:
                return
            pkt = bytes(buf[:total])
            if P.checksum(pkt[2:-1]) != pkt[-1]:
                del buf[:1]  # resynchronise on the next header
                self.stats["bad_checksum"] += 1
                continue
            del buf[:total]
            yield pkt

    def _status(self, servo: STS3215Emulator, params: bytes = b"") -> bytes:
        out = bytearray(P.packet(servo.id, servo.error_bits(), params))
        if self._corrupt and self._corrupt[0] in (None, servo.id):
            self._corrupt.pop(0)
            out[-1] ^= 0x5A
            self.stats["corrupted"] += 1
        self.stats["status"] += 1
        return bytes(out)

    def _handle(self, pkt: bytes) -> bytes:
        sid, inst, params = pkt[2], pkt[4], pkt[5:-1]
        self.stats[f"inst_{inst:#04x}"] += 1
        if sid == P.BROADCAST_ID:
            return self._broadcast(inst, params)
        servo = self.servos.get(sid)
        if servo is None or not servo.responsive:
            return b""
        answer_all = servo.mem[8] >= 1  # RESPONSE_LEVEL
        if inst == P.PING:
            return self._status(servo)
        if inst == P.READ and len(params) == 2:
            return self._status(servo, servo.read(params[0], params[1]))
        if inst == P.WRITE and len(params) >= 2:
            servo.write(params[0], params[1:])
        elif inst == P.REG_WRITE and len(params) >= 2:
            servo.reg_write(params[0], params[1:])
        elif inst == P.ACTION:
            servo.action()
        else:
            self.stats["unknown_instruction"] += 1
            return b""
        return self._status(servo) if answer_all else b""

    def _broadcast(self, inst: int, params: bytes) -> bytes:
        if inst == P.SYNC_WRITE and len(params) >= 2:
            address, length = params[0], params[1]
            body = params[2:]
            for k in range(0, len(body) - length, length + 1):
                servo = self.servos.get(body[k])
                if servo is not None and servo.responsive:
                    servo.write(address, body[k + 1:k + 1 + length])
            return b""
        if inst == P.SYNC_READ and len(params) >= 2:
            address, length = params[0], params[1]
            out = bytearray()
            for sid in params[2:]:
                servo = self.servos.get(sid)
                if servo is not None and servo.responsive:
                    out += self._status(servo, servo.read(address, length))
            return bytes(out)
        if inst == P.WRITE and len(params) >= 2:
            for servo in self.servos.values():
                servo.write(params[0], params[1:])
        elif inst == P.ACTION:
            for servo in self.servos.values():
                servo.action()
        return b""
