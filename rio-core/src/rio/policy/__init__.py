"""Policy deployment: the policy interface plugins implement (`Policy`), the node hosting one
(`PolicyNode`), asynchronous chunked inference (`AsyncInference`, `ChunkSchedule`) and the
inference script behind `rio deploy` (`run_deploy`). See docs/policies.md."""

from .async_inference import AsyncConfig, AsyncInference
from .base import ActionChunk, Policy, PolicyConfig, PolicyMetadata
from .node import PolicyNode
from .obs_layout import ObsLayout
from .schedule import ChunkSchedule, ScheduleConfig

__all__ = ["Policy", "PolicyConfig", "PolicyMetadata", "ActionChunk", "PolicyNode", "ObsLayout", "ChunkSchedule",
           "ScheduleConfig", "AsyncConfig", "AsyncInference", "run_deploy"]


def __getattr__(name: str):
    if name == "run_deploy":  # pulls in the station machinery; only when asked for
        from .deploy import run_deploy

        return run_deploy
    raise AttributeError(f"module 'rio.policy' has no attribute '{name}'")
