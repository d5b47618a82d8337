"""rio-so100: SO-100 / SO-101 arms on the Feetech bus for RIO.

Drivers (`follower`, `gripper`, `leader`, one folder each with its config model), the bus layer on
`scservo_sdk` (`feetech`), calibration kept apart from driver logic (`calibration`, `calibrate`),
per-tick safety (`safety`), a virtual bus speaking the STS3215 protocol on a pty (`virtual`), and
leader arms for `rio teleop` (the mirroring loop is core's rio.teleop.leader_follower).
Importing this package imports no vendor SDK.
"""
