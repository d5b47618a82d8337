"""rio-policies' plugin module (entry point group `rio`): policy specs only, nothing imported."""

from __future__ import annotations

from rio.hookspecs import hookimpl
from rio.specs import Spec

_P = "rio_policies"


@hookimpl
def rio_policies() -> list[Spec]:
    return [
        Spec("openpi.remote", "policy", f"{_P}.openpi:OpenPINode",
             "an openpi policy server (pi0, pi0.5) over its websocket + msgpack protocol",
             config=f"{_P}.openpi:OpenPIConfig"),
        Spec("gr00t.remote", "policy", f"{_P}.gr00t:Gr00tNode",
             "an Isaac-GR00T inference server (N1.5 / N1.6) over its ZMQ request/reply protocol",
             config=f"{_P}.gr00t:Gr00tConfig"),
        Spec("lerobot.local", "policy", f"{_P}.lerobot_policy:LeRobotNode",
             "a LeRobot ACT or Diffusion checkpoint from a local directory (needs lerobot)",
             config=f"{_P}.lerobot_policy:LeRobotConfig"),
        Spec("onnx.local", "policy", f"{_P}.onnx_policy:OnnxNode",
             "an ONNX model (RL locomotion, exported policies) on onnxruntime",
             config=f"{_P}.onnx_policy:OnnxConfig"),
        Spec("replay.episode", "policy", f"{_P}.replay:ReplayNode",
             "plays back the actions of a recorded episode, time-aligned",
             config=f"{_P}.replay:ReplayConfig"),
    ]
