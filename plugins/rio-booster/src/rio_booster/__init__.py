"""rio-booster: the Booster Robotics T1 humanoid on booster-robotics-sdk-python."""
