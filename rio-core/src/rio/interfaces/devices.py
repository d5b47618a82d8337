"""The station fields every device of one sort has, declared and validated once for every plugin.

- `NetworkDevice`: a device reached over IP (an arm's controller, a gripper behind it): its address,
  checked to be a dotted IPv4 address (vendor SDKs take anything else for a serial port or a host name and
  fail far from the typo), and how long `open()` keeps trying to reach it.
- `ServoBus`: a device on a serial bus (a chain of servos, a Modbus RTU line): the port, its baud rate and
  how often a failed exchange is retried.

A driver mixes the one it is into its `Config` (`class Config(NetworkDevice, ArmNode.Config)`) and sets
its hardware's defaults in the Config's `defaults` (`defaults = {"baudrate": 57600}`, `rio.config`), so
the description and the constraints stay the same everywhere. A driver whose address may also be a host
name (a socket's, the Robotiq URCap's; the Vision Pro's) redeclares `ip` as a plain `str` and says why.
"""

from __future__ import annotations

import ipaddress
from typing import Annotated

from pydantic import AfterValidator, Field

from rio.config import Config


def dotted_ipv4(value: str) -> str:
    """`value` as a dotted IPv4 address (surrounding blanks dropped), or a ValueError saying what is expected."""
    try:
        return str(ipaddress.IPv4Address(value.strip()))
    except ValueError:
        raise ValueError(f"'{value}' is not an IPv4 address like 192.168.1.185 (the device's, as set on it or "
                         "printed on its label)") from None


#: A dotted IPv4 address, validated (`dotted_ipv4`).
IPv4 = Annotated[str, AfterValidator(dotted_ipv4)]


class NetworkDevice(Config):
    """Station fields of a device reached over IP."""

    ip: IPv4 = Field(description="the device's IPv4 address (its controller's, as set on it or printed on its "
                                 "label; an emulator prints its own)")
    connect_timeout_s: float = Field(5.0, ge=0, description="keep trying to connect this long at start (s): a "
                                                            "controller still booting answers after a while")


class ServoBus(Config):
    """Station fields of a device on a serial bus."""

    #: "virtual" was the emulator's port value until the stand-ins got one word each (fake, emulator, sim).
    renamed_values = {"port": {"virtual": "emulator"}}
    port: str = Field(description='the bus\'s serial port (e.g. /dev/ttyUSB0; a /dev/serial/by-id/ path survives '
                                  're-plugging), or "emulator" for an emulated device inside the driver')
    baudrate: int = Field(1_000_000, gt=0, description="baud rate (the devices' setting)")
    retries: int = Field(2, ge=0, le=10, description="retries of a failed exchange before it is an error")
