"""GELLO leader arms: Dynamixel XL330 servos on a U2D2 (Protocol 2.0, dynamixel-sdk), read as the
follower's joint angles through a per-leader calibration (offsets that are multiples of pi/2, signs).

- `layouts`: xArm 7, UR5e, FR3, Panda (ids, signs, known calibration pose, trigger travel);
- `calibration`: offsets (and signs) from the leader held in a known pose; files;
- `bus`: opening the U2D2 through dynamixel-sdk, presence checks, Sync Read;
- `driver`: the `gello.*` teleop nodes (leader arms for `rio teleop`);
- `emulator`: a Protocol 2.0 bus on a pseudo-terminal (`port = "emulator"`);
- `specs`: what the plugin registers (no SDK import).
"""
