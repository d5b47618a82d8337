"""Building blocks for the device emulators plugins test their drivers against: the vendor SDK talks
its real protocol to a server we write (a pseudo-terminal serial device, a TCP socket), whose device
model moves like the hardware would.

- `PtyDevice`: a serial device on a pseudo-terminal (the driver opens its path like a USB adapter);
- `TcpDevice`: a TCP server, one thread per connection, that can drop its clients on demand;
- `FingerModel`: a parallel gripper's fingers (speed, force, an object that stops them);
- `modbus`: Modbus RTU, the protocol of RS-485 grippers and tools, written once for every emulator
  that speaks it: `RegisterSlave` (a register map answering functions 3/4/6/16 with exceptions
  1/2/3, on frames without CRC), `ModbusRtuDevice` (RTU framing on a `PtyDevice` around slaves),
  `crc16` / `with_crc` / `frame_length`;
- `free_loopback(ports)`: a 127.0.0.N address of its own for an emulator whose SDK dials fixed ports.
"""

from rio.emulation.finger import FingerModel
from rio.emulation.loopback import can_listen, free_loopback, is_free
from rio.emulation.modbus import (
           ILLEGAL_DATA_ADDRESS,
           ILLEGAL_DATA_VALUE,
           ILLEGAL_FUNCTION,
           ModbusError,
           ModbusRtuDevice,
           RegisterSlave,
           crc16,
           frame_length,
           in_block,
           with_crc,
)
from rio.emulation.pty import PtyDevice
from rio.emulation.tcp import TcpDevice

__all__ = ["FingerModel", "PtyDevice", "TcpDevice", "RegisterSlave", "ModbusRtuDevice", "ModbusError",
           "ILLEGAL_FUNCTION", "ILLEGAL_DATA_ADDRESS", "ILLEGAL_DATA_VALUE", "crc16", "with_crc", "frame_length",
           "in_block", "free_loopback", "is_free", "can_listen"]
