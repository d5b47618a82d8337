"""rio-unitree: the Unitree G1 humanoid over DDS (unitree_sdk2py), its hands, and a MuJoCo DDS bridge."""
