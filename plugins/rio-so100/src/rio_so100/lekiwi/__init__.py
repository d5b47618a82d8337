"""LeKiwi: an SO-101 arm on a three-wheel omni base whose wheels are STS3215 servos (ids 7, 8, 9) in wheel
mode on the arm's own Feetech bus. The arm is this plugin's follower and gripper; the base is `wheels`."""
