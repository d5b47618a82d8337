"""`FeetechBus`: the driver side of a Feetech serial bus, on top of `scservo_sdk`.

What it adds to the SDK, and why:

- retries: a status packet with a bad checksum (EMI on a long cable) is retried `retries` times,
  after dropping whatever is left of the failed exchange, and only then reported;
- errors that name the port, the operation and the servo (id and joint): a silent id is a cable or
  id problem the user can fix, "timeout" alone is not;
- the error byte of every status packet, which the SDK's GroupSyncRead drops, so the drivers can
  stop on overload, overheat or voltage faults;
- a port lock per transaction (`PortLock`), so an arm node and a gripper node can share one bus;
- a read that blocks for at most 1 ms (`rio.machine.servo_port`) instead of spinning on a zero-timeout port, which
  leaves the CPU (and the GIL) to the rest of the node.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Mapping

try:  # what pyserial's POSIX port raises when its device is unplugged under it (not an OSError)
    from termios import error as TermiosError
except ImportError:  # Windows
    TermiosError = OSError  # type: ignore[misc, assignment]

from rio.machine.servo_port import port_handler

from ..errors import BusError, ServoFault
from . import control_table as T
from .port_lock import PortLock

#: Result code of an exchange that raised an I/O error (the SDK's codes are 0 and negatives down to -9).
IO_ERROR = -100
#: After a failed exchange, wait this long for the rest of it to arrive, then drop it.
DRAIN_S = 0.002


def _sdk():
    import scservo_sdk  # imported on first use: listing drivers must not need the SDK

    return scservo_sdk


def _sync_read(port, ph, address: int, length: int):
    """A GroupSyncRead that keeps each status packet's error byte and the id that failed."""
    scs = _sdk()

    class SyncRead(scs.GroupSyncRead):
        def rxPacket(self):  # noqa: N802 (SDK name)
            self.errors, self.failed = {}, None
            result = scs.COMM_RX_FAIL
            for sid in self.data_dict:
                self.data_dict[sid], result, self.errors[sid] = self.ph.readRx(self.port, sid, self.data_length)
                if result != scs.COMM_SUCCESS:
                    self.failed = sid
                    return result
            return result

    return SyncRead(port, ph, address, length)


class FeetechBus:
    """One serial bus. `names` maps servo ids to joint names for error messages."""

    def __init__(self, port: str, *, baudrate: int = 1_000_000, retries: int = 2,
                 names: Mapping[int, str] | None = None):
        self.port, self.baudrate, self.retries = port, int(baudrate), int(retries)
        self.names = dict(names or {})
        self._ph = self._pk = None
        self._lock: PortLock | None = None
        self._readers: dict[tuple, object] = {}
        #: Counters for diagnostics and benchmarks.
        self.retried = 0
        self.last_io_error = ""

    # -- lifecycle -----------------------------------------------------------------------------------
    def open(self) -> FeetechBus:
        scs = _sdk()
        self._lock = PortLock(self.port)
        ph = port_handler(_sdk().PortHandler, self.port)
        try:
            with self._lock:  # opening flushes the tty's input: not in the middle of someone's exchange
                ok = ph.openPort() and ph.setBaudRate(self.baudrate)
        except Exception as e:  # serial.SerialException, OSError
            raise BusError(f"cannot open Feetech bus on {self.port}: {e}") from None
        if not ok:
            raise BusError(f"cannot open Feetech bus on {self.port} at {self.baudrate} baud")
        self._ph, self._pk = ph, scs.PacketHandler(0)  # protocol end 0: STS series, little-endian
        return self

    def close(self) -> None:
        if self._ph is not None:
            try:
                self._ph.closePort()
            except Exception:
                pass
            self._ph = None
        if self._lock is not None:
            self._lock.close()
            self._lock = None
        self._readers.clear()

    def __enter__(self) -> FeetechBus:
        return self.open() if self._ph is None else self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- helpers -------------------------------------------------------------------------------------
    def servo_name(self, sid: int) -> str:
        return f"servo {sid}" + (f" ({self.names[sid]})" if sid in self.names else "")

    def _result(self, result: int) -> str:
        scs = _sdk()
        if result == IO_ERROR:
            return f"port error ({self.last_io_error})"
        return {scs.COMM_RX_TIMEOUT: "no answer (timeout)", scs.COMM_RX_CORRUPT: "corrupt status packet (checksum)",
                scs.COMM_TX_FAIL: "write to the port failed", scs.COMM_PORT_BUSY: "port busy"}.get(
                    result, self._pk.getTxRxResult(result) if self._pk else str(result))

    def _drain(self) -> None:
        time.sleep(DRAIN_S)
        try:
            self._ph.ser.reset_input_buffer()
        except Exception:
            pass
        self._ph.is_using = False

    def _guarded(self, fn):
        """Run one exchange on a clean input queue; an I/O error (a port that vanished, input taken
        by another opener) counts as a failed exchange, retried like the others."""
        try:
            self._ph.ser.reset_input_buffer()
            return fn()
        except (OSError, TermiosError) as e:  # serial.SerialException (and PortNotOpenError) are OSErrors
            self.last_io_error = f"{type(e).__name__}: {e}"
            return None, IO_ERROR, 0

    def _check_open(self) -> None:
        if self._ph is None:
            raise BusError(f"Feetech bus on {self.port} is not open")

    def _transact(self, what: str, sid: int | None, fn, check_error: bool = True):
        """Run `fn() -> (value, result, error_bits)` under the port lock, retrying failures; error
        bits in the answer raise `ServoFault` unless `check_error` is False."""
        self._check_open()
        scs = _sdk()
        result = scs.COMM_SUCCESS
        for attempt in range(self.retries + 1):
            with self._lock:
                value, result, error = self._guarded(fn)
                if result == scs.COMM_SUCCESS:
                    if error and check_error:
                        raise ServoFault(self.port, {sid: error}, self.names)
                    return value
                self._drain()
            if attempt < self.retries:
                self.retried += 1
        who = f" {self.servo_name(sid)}:" if sid is not None else ""
        raise BusError(f"{self.port}: {what}:{who} {self._result(result)} after {self.retries + 1} tries"
                       + ("; check its cable, power and id" if result == scs.COMM_RX_TIMEOUT else ""))

    # -- single servo --------------------------------------------------------------------------------
    def ping(self, sid: int) -> int:
        """Model number of servo `sid` (BusError naming it when it does not answer)."""
        return self._transact("ping", sid, lambda: self._pk.ping(self._ph, sid))

    def find(self, ids: Iterable[int]) -> dict[int, int | None]:
        """Model number of each id, None for the silent ones (no retries: a scan)."""
        out: dict[int, int | None] = {}
        scs = _sdk()
        self._check_open()
        for sid in ids:
            with self._lock:
                model, result, _ = self._guarded(lambda sid=sid: self._pk.ping(self._ph, sid))
                if result != scs.COMM_SUCCESS:
                    self._drain()
            out[sid] = model if result == scs.COMM_SUCCESS else None
        return out

    def read(self, sid: int, reg: tuple[int, int]) -> int:
        address, size = reg
        data = self._transact(f"read of address {address}", sid,
                              lambda: self._pk.readTxRx(self._ph, sid, address, size))
        value = T.from_bytes(data, 0, size)
        return T.decode_sign(value, T.SIGN_BITS[reg]) if reg in T.SIGN_BITS else value

    def write(self, sid: int, reg: tuple[int, int], value: int, *, check_error: bool = True) -> None:
        address, size = reg
        if reg in T.SIGN_BITS:
            value = T.encode_sign(value, T.SIGN_BITS[reg])
        data = T.to_bytes(value, size)
        self._transact(f"write of address {address}", sid,
                       lambda: (None, *self._pk.writeTxRx(self._ph, sid, address, size, data)), check_error)

    # -- many servos ---------------------------------------------------------------------------------
    def sync_read(self, ids: Iterable[int], address: int, length: int) -> tuple[dict[int, list[int]], dict[int, int]]:
        """One SYNC READ: ({id: bytes}, {id: error bits}). Error bits are returned, not raised: the
        caller decides how to stop."""
        ids = tuple(int(i) for i in ids)
        key = (ids, address, length)
        reader = self._readers.get(key)
        if reader is None:
            reader = _sync_read(self._ph, self._pk, address, length)
            for sid in ids:
                reader.addParam(sid)
            self._readers[key] = reader
        self._check_open()
        scs = _sdk()
        for attempt in range(self.retries + 1):
            with self._lock:
                _, result, _ = self._guarded(lambda: (None, reader.txRxPacket(), 0))
                if result == scs.COMM_SUCCESS:
                    return {sid: list(reader.data_dict[sid]) for sid in ids}, dict(reader.errors)
                self._drain()
            if attempt < self.retries:
                self.retried += 1
        failed = getattr(reader, "failed", None)
        who = f" {self.servo_name(failed)}:" if failed is not None else ""
        raise BusError(f"{self.port}: sync read of servos {list(ids)}:{who} {self._result(result)} after "
                       f"{self.retries + 1} tries" + ("; check its cable, power and id"
                                                     if result == scs.COMM_RX_TIMEOUT else ""))

    def sync_write(self, reg: tuple[int, int], values: Mapping[int, int]) -> None:
        """One SYNC WRITE of `reg` (no answers come back from a broadcast)."""
        self._check_open()
        scs = _sdk()
        address, size = reg
        writer = scs.GroupSyncWrite(self._ph, self._pk, address, size)
        for sid, value in values.items():
            v = T.encode_sign(value, T.SIGN_BITS[reg]) if reg in T.SIGN_BITS else int(value)
            writer.addParam(int(sid), T.to_bytes(v, size))
        with self._lock:
            _, result, _ = self._guarded(lambda: (None, writer.txPacket(), 0))
            self._ph.is_using = False
        if result != scs.COMM_SUCCESS:
            raise BusError(f"{self.port}: sync write of address {address}: {self._result(result)}")

    def write_all(self, ids: Iterable[int], reg: tuple[int, int], value: int) -> None:
        """The same value to each servo, one acknowledged write each (setup, not the hot path)."""
        for sid in ids:
            self.write(sid, reg, value)
