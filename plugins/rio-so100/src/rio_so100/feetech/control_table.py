"""STS3215 control table: the registers RIO uses, as (address, size in bytes).

Learned from Feetech's STS/SMS memory table (and LeRobot's notes on it). Multi-byte values are
little-endian. Registers below `EEPROM_END` live in EEPROM: the servo only takes writes there while
`LOCK` is 0, so calibration unlocks, writes and locks again. Positions are encoder steps, 4096 per
turn; the servo reports `PRESENT_POSITION = encoder - HOMING_OFFSET` (mod 4096).
"""

from __future__ import annotations

STEPS_PER_TURN = 4096
#: Model number an STS3215 answers at address 3 (the SDK's ping reads it).
STS3215_MODEL = 777

# -- EEPROM ------------------------------------------------------------------------------------------
MODEL_NUMBER = (3, 2)
ID = (5, 1)
BAUD_RATE = (6, 1)
RETURN_DELAY = (7, 1)            # 2 us units
RESPONSE_LEVEL = (8, 1)          # 0: answer only PING and READ; 1: answer every instruction
MIN_POSITION_LIMIT = (9, 2)
MAX_POSITION_LIMIT = (11, 2)
MAX_TEMPERATURE = (13, 1)        # deg C
MAX_VOLTAGE = (14, 1)            # 0.1 V
MIN_VOLTAGE = (15, 1)            # 0.1 V
MAX_TORQUE = (16, 2)             # 0.1 %
P_GAIN = (21, 1)
D_GAIN = (22, 1)
I_GAIN = (23, 1)
HOMING_OFFSET = (31, 2)          # sign-magnitude, sign in bit 11
OPERATING_MODE = (33, 1)         # 0: position servo, 1: wheel (constant speed: GOAL_VELOCITY, signed)
PROTECTIVE_TORQUE = (34, 1)      # % of max torque kept after an overload
PROTECTION_TIME = (35, 1)        # 10 ms units a load above OVERLOAD_TORQUE may last
OVERLOAD_TORQUE = (36, 1)        # %
EEPROM_END = 40

# -- SRAM --------------------------------------------------------------------------------------------
TORQUE_ENABLE = (40, 1)
ACCELERATION = (41, 1)
GOAL_POSITION = (42, 2)
GOAL_TIME = (44, 2)
GOAL_VELOCITY = (46, 2)          # position mode: speed cap, steps/s (0 = the servo's maximum); wheel mode:
                                 # the speed to turn at, steps/s, sign-magnitude with the sign in bit 15
TORQUE_LIMIT = (48, 2)           # 0.1 %
LOCK = (55, 1)
PRESENT_POSITION = (56, 2)
PRESENT_VELOCITY = (58, 2)       # steps/s, sign-magnitude, sign in bit 15
PRESENT_LOAD = (60, 2)           # 0.1 % of max torque, sign in bit 10
PRESENT_VOLTAGE = (62, 1)        # 0.1 V
PRESENT_TEMPERATURE = (63, 1)    # deg C
STATUS = (65, 1)                 # the same error bits as a status packet's error byte
MOVING = (66, 1)
PRESENT_CURRENT = (69, 2)

#: OPERATING_MODE values.
POSITION_MODE, VELOCITY_MODE = 0, 1

#: Sign bit of the sign-magnitude registers.
SIGN_BITS = {HOMING_OFFSET: 11, PRESENT_VELOCITY: 15, GOAL_VELOCITY: 15, PRESENT_LOAD: 10}

#: What the drivers read every cycle with one sync read: PRESENT_POSITION .. STATUS (10 bytes).
STATE_BLOCK = (PRESENT_POSITION[0], STATUS[0] + 1 - PRESENT_POSITION[0])


def encode_sign(value: int, sign_bit: int) -> int:
    """Signed int -> sign-magnitude register value."""
    mag = abs(int(value))
    if mag >= 1 << sign_bit:
        raise ValueError(f"{value} does not fit a sign-magnitude register with the sign in bit {sign_bit}")
    return mag | (1 << sign_bit) if value < 0 else mag


def decode_sign(raw: int, sign_bit: int) -> int:
    """Sign-magnitude register value -> signed int."""
    mag = raw & ((1 << sign_bit) - 1)
    return -mag if raw & (1 << sign_bit) else mag


def to_bytes(value: int, size: int) -> list[int]:
    return [(int(value) >> (8 * i)) & 0xFF for i in range(size)]


def from_bytes(data, offset: int, size: int) -> int:
    return sum(int(data[offset + i]) << (8 * i) for i in range(size))
