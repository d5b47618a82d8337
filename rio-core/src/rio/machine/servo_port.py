"""The serial port of a servo bus as RIO drivers want it, on top of a vendor SDK's `PortHandler`.

dynamixel-sdk and Feetech's scservo_sdk (and the SDKs forked from them) share one `PortHandler` API,
which polls a zero-timeout port while it waits for a status packet: a driver node spinning there takes
the CPU, and the GIL, from the rest of its process. Their drivers therefore use `port_handler`: reads
block for at most `READ_SLICE_S` (the SDK still checks its packet timeout between reads), and the packet
timeout can be raised to `min_timeout_ms` (an emulated servo answering from a thread on a loaded machine
needs more than the SDK's own, which suits a real bus)."""

from __future__ import annotations

from typing import Any

#: Longest a single port read blocks.
READ_SLICE_S = 0.001


def port_handler(base: type, port: str, min_timeout_ms: float = 0.0) -> Any:
    """An instance, for `port`, of the SDK's `PortHandler` class `base` with the two changes above."""

    class PortHandler(base):
        packet_timeout: float

        def setupPort(self, cflag_baud: Any) -> Any:  # noqa: N802 (SDK name)
            ok = super().setupPort(cflag_baud)
            self.ser.timeout = READ_SLICE_S
            return ok

        def setPacketTimeout(self, packet_length: Any) -> None:  # noqa: N802 (SDK name)
            super().setPacketTimeout(packet_length)
            self.packet_timeout = max(self.packet_timeout, min_timeout_ms)

    return PortHandler(port)
