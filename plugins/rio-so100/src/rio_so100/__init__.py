"""rio-so100: SO-100 / SO-101 arms on the Feetech bus for RIO.

Drivers (`follower`, `gripper`, `leader`, one folder each, their `Config` nested in the class; SO-101 is
the same drivers with a preset), the bus layer on `scservo_sdk` (`feetech`), calibration kept apart
from driver logic (`calibration`, `calibrate`), an emulated bus speaking the STS3215 protocol on a pty
(`emulator`), and leader arms for `rio teleop` (the mirroring loop is core's rio.teleop.leader_follower).
Per-tick safety is not here: the kinds in rio.interfaces own it for every driver.
Importing this package imports no vendor SDK.
"""
