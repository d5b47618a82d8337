"""The serial port of a servo bus as RIO drivers want it, on top of a vendor SDK's `PortHandler`.

dynamixel-sdk and Feetech's scservo_sdk (and the SDKs forked from them) share one `PortHandler` API,
which polls a zero-timeout port while it waits for a status packet: a driver node spinning there takes
the CPU, and the GIL, from the rest of its process. Their drivers therefore use `port_handler`: reads
block for at most `READ_SLICE_S` (the SDK still checks its packet timeout between reads), and a port that
a device of this very process emulates (`rio.emulation.PtyDevice` marks its pty here) waits at least
`EMULATED_SLACK_MS` for a status packet, whoever opens it (the station's own emulator, or one a script or test
made and handed the driver by its path): an emulated servo answers from a thread, which a loaded machine may
not schedule within the SDK's own timeout (that suits a real bus)."""

from __future__ import annotations

from typing import Any

#: Longest a single port read blocks.
READ_SLICE_S = 0.001
#: The packet timeout of a port emulated in this process: its servos answer when their thread gets the CPU.
EMULATED_SLACK_MS = 500.0

_EMULATED: set[str] = set()  # the ptys this process's emulated devices serve


def mark_emulated(port: str, emulated: bool = True) -> None:
    """Say that a device of this process serves `port` (or no longer does)."""
    (_EMULATED.add if emulated else _EMULATED.discard)(port)


def emulated_here(port: str) -> bool:
    """Whether a device of this process serves `port`."""
    return port in _EMULATED


def port_handler(base: type, port: str) -> Any:
    """An instance, for `port`, of the SDK's `PortHandler` class `base` with the two changes above."""

    class PortHandler(base):
        packet_timeout: float

        def setupPort(self, cflag_baud: Any) -> Any:  # noqa: N802 (SDK name)
            ok = super().setupPort(cflag_baud)
            self.ser.timeout = READ_SLICE_S
            return ok

        def setPacketTimeout(self, packet_length: Any) -> None:  # noqa: N802 (SDK name)
            super().setPacketTimeout(packet_length)
            if emulated_here(port):
                self.packet_timeout = max(self.packet_timeout, EMULATED_SLACK_MS)

    return PortHandler(port)
