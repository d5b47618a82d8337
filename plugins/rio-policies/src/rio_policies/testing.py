"""Test helpers shared by the plugins' tests of locomotion deploys (rio-policies, rio-unitree): small ONNX
models built with onnx's helper API (no checkpoint to download), and the G1 pose that stands.

Needs the `onnx` package (a test dependency; `onnxruntime` runs the models).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: unitree_rl_gym's G1 observation: 3 + 3 + 3 + 12 + 12 + 12 + 2 values.
N_OBS = 47

#: A pose the free G1 holds by itself with sim-g1-floating's gains (legs 300/3, ankles 300/15): feet flat,
#: centre of mass over the ankles. Unitree's default pose (hip pitch -0.1, ankle pitch -0.2) tips forward.
G1_STANDING: dict[str, float] = {f"{s}_{j}_joint": v for s in ("left", "right")
                                 for j, v in (("hip_pitch", -0.17), ("knee", 0.3), ("ankle_pitch", -0.13))}


def save(graph: object, path: str | Path) -> str:
    """Write an onnx graph as a checked opset-17 model; its path."""
    import onnx
    from onnx import helper

    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, str(path))
    return str(path)


def echo_model(path: str | Path, picks: list[int], gain: float = 1.0, n_in: int = N_OBS) -> str:
    """A model whose actions[k] = gain * obs[picks[k]] (a zero model when gain is 0): with a tiny gain it
    holds the default pose, and what it was given can be read back off its actions."""
    from onnx import TensorProto, helper, numpy_helper

    w = np.zeros((len(picks), n_in), np.float32)
    w[np.arange(len(picks)), picks] = gain
    graph = helper.make_graph([helper.make_node("Gemm", ["obs", "W"], ["actions"], transB=1)], "loco",
                              [helper.make_tensor_value_info("obs", TensorProto.FLOAT, [1, n_in])],
                              [helper.make_tensor_value_info("actions", TensorProto.FLOAT, [1, len(picks)])],
                              [numpy_helper.from_array(w, "W")])
    return save(graph, path)


def standing_policy(directory: str | Path, gain: float = 1e-4, **fields: object) -> tuple[str, str]:
    """A policy file for `rio deploy --policy FILE`: `onnx.locomotion` running `echo_model(obs[0:12] x gain)`
    (below 3e-5 rad on any target with the default gain: it holds `G1_STANDING`), plus `fields` (command,
    command_from, ...; lists, strings and numbers). Returns (the policy file, the model file)."""
    import json

    directory = Path(directory)
    model = echo_model(directory / "stand.onnx", list(range(12)), gain)
    pose = ", ".join(f"{k} = {v}" for k, v in G1_STANDING.items())
    extra = "".join(f"{k} = {json.dumps(v)}\n" for k, v in fields.items())
    spec = directory / "policy.toml"
    spec.write_text(f'[policy]\ndriver = "onnx.locomotion"\npath = "{model}"\n{extra}default_pose = {{ {pose} }}\n')
    return str(spec), model
