"""Policy deployment: the policy interface plugins implement (`Policy`), the node hosting one
(`PolicyNode`), asynchronous chunked inference (`AsyncInference`, `ChunkSchedule`) and the
controller behind `rio deploy` (`deploy.PolicyController`; the workflow is `rio.workflows.deploy`).
See docs/policies.md."""

from rio.policy.async_inference import AsyncConfig, AsyncInference
from rio.policy.base import ActionChunk, Policy, PolicyConfig, PolicyError, PolicyMetadata
from rio.policy.node import PolicyNode
from rio.policy.obs_layout import ObsLayout
from rio.policy.schedule import ChunkSchedule, ScheduleConfig

__all__ = ["Policy", "PolicyConfig", "PolicyError", "PolicyMetadata", "ActionChunk", "PolicyNode", "ObsLayout",
           "ChunkSchedule", "ScheduleConfig", "AsyncConfig", "AsyncInference"]

