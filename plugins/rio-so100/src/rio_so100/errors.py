"""Errors of the SO-100 drivers. Each names the port and, when one servo is at fault, its id and
joint, so a user knows which cable to check or which motor is hot."""

from __future__ import annotations

from rio.errors import RioError

from .feetech.protocol import describe_error


class BusError(RioError):
    """The bus did not deliver: a port that does not open, a servo that does not answer, packets
    that stay corrupt after retries."""


class ServoFault(RioError):
    """A servo reported error bits (overload, overheat, voltage, ...): the arm was stopped."""

    def __init__(self, port: str, faults: dict[int, int], names: dict[int, str] | None = None):
        self.port, self.faults = port, dict(faults)
        names = names or {}
        parts = [f"servo {sid}" + (f" ({names[sid]})" if sid in names else "") + f": {describe_error(bits)}"
                 for sid, bits in sorted(self.faults.items())]
        super().__init__(f"{port}: stopped on servo error: " + "; ".join(parts))


class CalibrationError(RioError):
    """No calibration, or one that does not fit the arm."""
