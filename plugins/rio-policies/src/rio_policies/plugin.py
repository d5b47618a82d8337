"""rio-policies' plugin module (entry point group `rio`): policy specs only, nothing imported."""

from __future__ import annotations

from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec

_P = "rio_policies"


@hookimpl
def rio_policies() -> list[Spec]:
    return [
        Spec("openpi.remote", "policy", f"{_P}.openpi:OpenPINode",
             "an openpi policy server (pi0, pi0.5) over its websocket + msgpack protocol"),
        Spec("gr00t.remote", "policy", f"{_P}.gr00t:Gr00tNode",
             "an Isaac-GR00T inference server (N1.5 / N1.6) over its ZMQ request/reply protocol"),
        Spec("lerobot.local", "policy", f"{_P}.lerobot_policy:LeRobotNode",
             "a LeRobot ACT or Diffusion checkpoint from a local directory (needs lerobot)"),
        Spec("onnx.local", "policy", f"{_P}.onnx_policy:OnnxNode",
             "an ONNX model (RL locomotion, exported policies) on onnxruntime"),
        Spec("onnx.locomotion", "policy", f"{_P}.locomotion:LocomotionNode",
             "RL locomotion on a humanoid (a legged_gym / unitree_rl_gym ONNX actor): velocity in, joints out"),
        Spec("replay.episode", "policy", f"{_P}.replay:ReplayNode",
             "plays back the actions of a recorded episode, time-aligned"),
    ]


@hookimpl
def rio_requirements() -> list[Requirement]:
    """What each adapter imports when its node starts (openpi.remote: websockets; gr00t.remote: pyzmq, a
    core dependency; replay.episode: nothing extra)."""
    return [
        Requirement("websockets", "pip install websockets", "openpi.remote: the openpi server's websocket protocol"),
        Requirement("onnxruntime", "pip install 'rio-policies[onnx]'",
                    "onnx.local, onnx.locomotion: running ONNX models"),
        Requirement("lerobot", "pip install 'lerobot==0.4.4'", "lerobot.local: ACT and Diffusion checkpoints"),
        Requirement("torch", "pip install torch", "lerobot.local: the checkpoint's model (lerobot's torch)"),
    ]
