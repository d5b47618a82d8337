"""A MuJoCo G1 behind the robot's DDS topics (`Bridge`), for laptops and CI: see `sim.py`."""

from .sim import Bridge, Counts

__all__ = ["Bridge", "Counts"]
