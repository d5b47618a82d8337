"""rio-robotiq: Robotiq 2F-85, 2F-140 and Hand-E grippers (Modbus RTU on an RS-485 adapter, or the
UR URCap socket) and DH-Robotics AG-95 / AG-105-145 grippers (Modbus RTU), in RIO's gripper contract,
with emulators of their wire protocols.

Layout: `models` (strokes and ranges per model, SI <-> register units), `robotiq/` and `dh/` (one
driver per vendor over a small link per transport), `emulator/` (register models, the RTU framing on a
pseudo-terminal, the URCap server), `plugin` (the specs). Importing this package loads no serial or
Modbus library: drivers import them in `open()`.
"""
