"""Embodiments: SingleArm, Bimanual and Humanoid, registered through the `rio_embodiments` hook."""

from .base import Embodiment, EmbodimentConfig
from .bimanual import Bimanual
from .humanoid import Humanoid
from .single_arm import ArmEmbodimentConfig, SingleArm

__all__ = ["Embodiment", "EmbodimentConfig", "ArmEmbodimentConfig", "SingleArm", "Bimanual", "Humanoid"]
