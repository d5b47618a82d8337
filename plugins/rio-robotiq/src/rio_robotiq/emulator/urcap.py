"""`UrcapServer`: the Robotiq URCap's gripper socket (port 63352 on a UR controller) over a
`RobotiqRegisters`, so the URCap driver runs its real socket code against the same gripper model as the
Modbus one.

Protocol (one request per line, one reply each):
    SET <VAR> <value> [<VAR> <value> ...]   -> "ack"  (no line end, as the URCap sends it)
    GET <VAR>                               -> "<VAR> <value>\\n"
Writable: ACT GTO ATR ADR POS SPE FOR (rACT rGTO rATR rARD rPR rSP rFR). Readable: those, and STA OBJ
FLT PRE (gSTA gOBJ gFLT gPR); GET POS and GET ACT/GTO read the gripper's status (gPO, gACT, gGTO), as
the URCap does. SID (the gripper's slave id, for several grippers on one URCap) is accepted and
ignored. Anything else answers "?\\n": an emulator's choice, so a driver bug fails fast.

The server binds 127.0.0.1 and a free port by default (`port` after `start()`); `drop_clients()`
(from `TcpDevice`) cuts connections for reconnect tests.
"""

from __future__ import annotations

import socket
from typing import Any

from rio.emulation import TcpDevice

from .registers import RobotiqRegisters

_SET = {"ACT": "rACT", "GTO": "rGTO", "ATR": "rATR", "ADR": "rARD", "POS": "rPR", "SPE": "rSP", "FOR": "rFR"}
_GET_STATUS = {"ACT": "gACT", "GTO": "gGTO", "STA": "gSTA", "OBJ": "gOBJ", "FLT": "gFLT", "POS": "gPO",
               "PRE": "gPR"}
_GET_REQUEST = {"ATR": "rATR", "ADR": "rARD", "SPE": "rSP", "FOR": "rFR"}


class UrcapServer(TcpDevice):
    def __init__(self, registers: RobotiqRegisters | None = None, host: str = "127.0.0.1", port: int = 0):
        super().__init__(host, port)
        self.registers = registers if registers is not None else RobotiqRegisters()
        #: every line received, for tests
        self.lines: list[str] = []

    def serve(self, conn: socket.socket, addr: Any) -> None:
        for line in self.read_lines(conn, "ascii", "replace", bufsize=1024):
            text = line.strip()
            if text:
                conn.sendall(self.answer(text))

    def answer(self, line: str) -> bytes:
        """The reply to one request line."""
        self.lines.append(line)
        words = line.split()
        verb, args = words[0].upper(), words[1:]
        try:
            if verb == "SET" and args and len(args) % 2 == 0:
                fields = {}
                for var, value in zip(args[::2], args[1::2], strict=True):
                    var = var.upper()
                    if var == "SID":
                        continue
                    fields[_SET[var]] = int(value)
                if any(not 0 <= v <= 255 for v in fields.values()):
                    return b"?\n"
                if fields:
                    self.registers.set_request(**fields)
                return b"ack"
            if verb == "GET" and len(args) == 1:
                name = args[0].upper()
                if name in _GET_STATUS:
                    reading = self.registers.status()[_GET_STATUS[name]]
                else:
                    reading = self.registers.request()[_GET_REQUEST[name]]
                return f"{name} {reading}\n".encode("ascii")
        except (KeyError, ValueError):
            pass
        return b"?\n"
