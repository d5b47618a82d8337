"""DH-Robotics AG series register map (AG-95 / AG-105-145 short manual, Modbus-RTU): 115200 8N1, slave
id 1 by default; control registers are read with function 3 and written with function 6.

Position is per mille of the stroke with 0 = closed and 1000 = open (the opposite of Robotiq's
counts), force is per cent of the maximum grip force (20..100), speed per cent (1..100).
"""

from __future__ import annotations

DEFAULT_SLAVE_ID = 1

# control (read/write)
INIT = 0x0100  # write 1: initialize; 0xA5: full initialization (finds both ends)
FORCE = 0x0101
POSITION = 0x0103
SPEED = 0x0104

# feedback (read only), read together as three registers from INIT_STATE
INIT_STATE = 0x0200
GRIP_STATE = 0x0201
POSITION_NOW = 0x0202

INIT_NONE, INIT_DONE, INIT_RUNNING = 0, 1, 2
GRIP_MOVING, GRIP_AT_POSITION, GRIP_CAUGHT, GRIP_DROPPED = 0, 1, 2, 3

INIT_STATES = {INIT_NONE: "not initialized", INIT_DONE: "initialized", INIT_RUNNING: "initializing"}
GRIP_STATES = {GRIP_MOVING: "moving", GRIP_AT_POSITION: "at position", GRIP_CAUGHT: "object caught",
               GRIP_DROPPED: "object dropped"}
