"""Building blocks for the device emulators plugins test their drivers against: the vendor SDK talks
its real protocol to a server we write (a pseudo-terminal serial device, a TCP socket), whose device
model moves like the hardware would.

- `PtyDevice`: a serial device on a pseudo-terminal (the driver opens its path like a USB adapter);
- `TcpDevice`: a TCP server, one thread per connection, that can drop its clients on demand;
- `FingerModel`: a parallel gripper's fingers (speed, force, an object that stops them).
"""

from .finger import FingerModel
from .pty import PtyDevice
from .tcp import TcpDevice

__all__ = ["FingerModel", "PtyDevice", "TcpDevice"]
