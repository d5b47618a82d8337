"""Embodiments: SingleArm, Bimanual, Humanoid and MobileManipulator, registered through the `rio_embodiments`
hook."""

from rio.embodiments.base import Embodiment, EmbodimentConfig
from rio.embodiments.bimanual import Bimanual
from rio.embodiments.humanoid import Humanoid
from rio.embodiments.mobile import MobileManipulator
from rio.embodiments.single_arm import ArmEmbodimentConfig, SingleArm

__all__ = ["Embodiment", "EmbodimentConfig", "ArmEmbodimentConfig", "SingleArm", "Bimanual", "Humanoid",
           "MobileManipulator"]
