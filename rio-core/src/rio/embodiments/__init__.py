"""Embodiments: SingleArm, Bimanual and Humanoid, registered through the `rio_embodiments` hook."""

from .base import Embodiment, EmbodimentOptions
from .bimanual import Bimanual
from .humanoid import Humanoid
from .single_arm import ArmOptions, SingleArm

__all__ = ["Embodiment", "EmbodimentOptions", "ArmOptions", "SingleArm", "Bimanual", "Humanoid"]
