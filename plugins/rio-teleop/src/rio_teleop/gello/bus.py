"""`DynamixelBus`: a GELLO's U2D2 through dynamixel-sdk (Protocol 2.0), with errors a user can act on.

What it adds to the SDK:
- one error naming the port and the id (and joint) for a port that does not open, servos that do not
  answer a ping, a read that fails after retries;
- a port read that blocks for at most 1 ms (`rio.machine.servo_port`) instead of spinning on a zero-timeout port
  (the SDK polls), which leaves the CPU and the GIL to the rest of the node;
- one Sync Read of Present Velocity + Present Position (addresses 128-135) for all servos.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Mapping

import numpy as np

from rio.errors import RioError
from rio.machine.servo_port import port_handler

from . import control_table as T
from . import protocol as P

_STATE = (T.PRESENT_VELOCITY[0], 8)


class BusError(RioError):
    """The Dynamixel bus did not deliver: a port that does not open, a servo that does not answer."""


def _sdk():
    import dynamixel_sdk  # on first use: listing drivers must not need the SDK

    return dynamixel_sdk


class DynamixelBus:
    def __init__(self, port: str, *, baudrate: int = 57600, retries: int = 2, names: Mapping[int, str] | None = None,
                 label: str | None = None):
        """`label`: how errors name the port (the station's "emulator" rather than a pty path)."""
        self.port, self.baudrate, self.retries = port, int(baudrate), int(retries)
        self.label = label or port
        self.names = dict(names or {})
        self._ph = self._pk = None
        self._reader = None
        self.retried = 0

    def open(self) -> DynamixelBus:
        sdk = _sdk()
        ph = port_handler(_sdk().PortHandler, self.port)
        try:
            ok = ph.openPort() and ph.setBaudRate(self.baudrate)
        except Exception as e:  # serial.SerialException, OSError
            raise BusError(f"cannot open the GELLO's Dynamixel bus on {self.label}: {e} (is the U2D2 plugged in? "
                           "see /dev/serial/by-id/)") from None
        if not ok:
            raise BusError(f"cannot open the GELLO's Dynamixel bus on {self.label} at {self.baudrate} baud")
        self._ph, self._pk = ph, sdk.PacketHandler(2.0)
        return self

    def close(self) -> None:
        if self._ph is not None:
            try:
                self._ph.closePort()
            except Exception:
                pass
            self._ph = None
        self._reader = None

    def __enter__(self) -> DynamixelBus:
        return self.open() if self._ph is None else self

    def __exit__(self, *exc) -> None:
        self.close()

    def servo_name(self, sid: int) -> str:
        return f"id {sid}" + (f" ({self.names[sid]})" if sid in self.names else "")

    def _flush(self) -> None:
        try:
            self._ph.ser.reset_input_buffer()
        except Exception:
            pass
        self._ph.is_using = False

    # -- single servo ---------------------------------------------------------------------------------
    def find(self, ids: Iterable[int]) -> dict[int, int | None]:
        """Model number of each id, None for the silent ones."""
        sdk = _sdk()
        out: dict[int, int | None] = {}
        for sid in ids:
            model = None
            for _ in range(self.retries + 1):
                m, result, _ = self._pk.ping(self._ph, int(sid))
                if result == sdk.COMM_SUCCESS:
                    model = int(m)
                    break
                self._flush()
            out[int(sid)] = model
        return out

    def check_present(self, ids: Iterable[int]) -> dict[int, int]:
        """Every id answers a ping, or one BusError naming the port and the ids that did not."""
        found = self.find(ids)
        missing = [sid for sid, m in found.items() if m is None]
        if missing:
            who = ", ".join(self.servo_name(s) for s in missing)
            answered = sorted(s for s, m in found.items() if m is not None)
            hint = ("nothing answered: check the U2D2's cable and the leader's 5 V power, and the baud rate"
                    if not answered else "check that servo's cable and its id (Dynamixel Wizard)")
            raise BusError(f"GELLO on {self.label}: Dynamixel {who} did not answer a ping at {self.baudrate} baud "
                           f"(ids that did: {answered or 'none'}); {hint}")
        return {sid: int(m) for sid, m in found.items()}

    def write(self, sid: int, reg: tuple[int, int], value: int) -> None:
        sdk = _sdk()
        address, size = reg
        data = list(P.le(value, size))
        result, error = sdk.COMM_TX_FAIL, 0
        for _ in range(self.retries + 1):
            result, error = self._pk.writeTxRx(self._ph, int(sid), address, size, data)
            if result == sdk.COMM_SUCCESS:
                break
            self._flush()
        if result != sdk.COMM_SUCCESS or error & 0x7F:
            what = self._pk.getTxRxResult(result) if result != sdk.COMM_SUCCESS else self._pk.getRxPacketError(error)
            raise BusError(f"GELLO on {self.label}: write of address {address} to Dynamixel {self.servo_name(sid)} "
                           f"failed: {what.split('] ')[-1]}")

    def read(self, sid: int, reg: tuple[int, int]) -> int:
        sdk = _sdk()
        address, size = reg
        for _ in range(self.retries + 1):
            data, result, _ = self._pk.readTxRx(self._ph, int(sid), address, size)
            if result == sdk.COMM_SUCCESS:
                return P.signed(data, size)
            self._flush()
        raise BusError(f"GELLO on {self.label}: read of address {address} from Dynamixel {self.servo_name(sid)}: "
                       f"{self._pk.getTxRxResult(result).split('] ')[-1]}")

    # -- all servos -----------------------------------------------------------------------------------
    def read_state(self, ids: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
        """One Sync Read: (positions rad, velocities rad/s) of `ids`, multi-turn as the servos count."""
        sdk = _sdk()
        if self._reader is None:
            self._reader = sdk.GroupSyncRead(self._ph, self._pk, *_STATE)
            for sid in ids:
                self._reader.addParam(int(sid))
        r = self._reader
        result = sdk.COMM_TX_FAIL
        for attempt in range(self.retries + 1):
            for sid in ids:
                r.data_dict[sid] = []
            result = r.txRxPacket()
            if result == sdk.COMM_SUCCESS:
                pos = np.array([P.signed(r.data_dict[s][4:8]) for s in ids], float) * T.RAD_PER_STEP
                vel = np.array([P.signed(r.data_dict[s][0:4]) for s in ids], float) * T.RAD_S_PER_VELOCITY_UNIT
                return pos, vel
            self._flush()
            if attempt < self.retries:
                self.retried += 1
                time.sleep(0.001)
        failed = next((s for s in ids if not r.data_dict[s]), None)
        who = f" {self.servo_name(failed)}" if failed is not None else ""
        raise BusError(f"GELLO on {self.label}: Dynamixel{who} did not answer the position read "
                       f"({self._pk.getTxRxResult(result).split('] ')[-1]}) after {self.retries + 1} tries; check its "
                       "cable and power")
