"""An emulated Dynamixel bus (Protocol 2.0 on a pseudo-terminal) and an emulated GELLO on it, so the
unmodified dynamixel-sdk, and the GELLO driver above it, run without a leader arm."""

from .bus import DynamixelBusEmulator
from .gello import GelloEmulator, emulator_mounting
from .servo import XL330Emulator

__all__ = ["DynamixelBusEmulator", "GelloEmulator", "XL330Emulator", "emulator_mounting"]
