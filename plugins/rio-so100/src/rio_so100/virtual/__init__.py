"""A virtual Feetech bus: STS3215 servos emulated behind a pseudo-terminal, so the real
`scservo_sdk` code path (and the RIO drivers above it) runs without an arm.

`VirtualBus(ids)` opens a pty, serves the protocol from a thread and exposes the slave path as
`.port`; `VirtualServo` is one servo's register memory plus a first-order position model.
"""

from .bus import VirtualBus
from .servo import VirtualServo

__all__ = ["VirtualBus", "VirtualServo"]
