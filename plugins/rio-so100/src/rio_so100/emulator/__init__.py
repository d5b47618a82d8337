"""An emulated Feetech bus: STS3215 servos emulated behind a pseudo-terminal, so the real
`scservo_sdk` code path (and the RIO drivers above it) runs without an arm.

`FeetechBusEmulator(ids)` opens a pty, serves the protocol from a thread and exposes the slave path as
`.port`; `STS3215Emulator` is one servo's register memory plus a first-order position model.
"""

from .bus import FeetechBusEmulator
from .servo import STS3215Emulator

__all__ = ["FeetechBusEmulator", "STS3215Emulator"]
