"""Embodiments: SingleArm, Bimanual and Humanoid, registered through the `rio_embodiments` hook."""

from rio.embodiments.base import Embodiment, EmbodimentConfig
from rio.embodiments.bimanual import Bimanual
from rio.embodiments.humanoid import Humanoid
from rio.embodiments.single_arm import ArmEmbodimentConfig, SingleArm

__all__ = ["Embodiment", "EmbodimentConfig", "ArmEmbodimentConfig", "SingleArm", "Bimanual", "Humanoid"]
