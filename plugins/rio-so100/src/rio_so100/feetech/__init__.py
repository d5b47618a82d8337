"""The Feetech serial bus: the STS3215 control table and wire protocol facts (shared by the driver
side and the emulated bus), and `FeetechBus`, the driver side's wrapper around `scservo_sdk`."""
