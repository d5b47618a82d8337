"""What retargeting costs inside the teleop loop (`python bench/retarget.py [--json]`).

A hand-tracking teleop cycle solves each dexterous hand (`rio.kinematics.HandRetargeter`: 20-joint test
hand, keypoints of a hand closing into a fist over the run, warm-started as in the loop) and a
humanoid's two wrists together (`rio.kinematics.MultiFrameIK`, the test upper body, wrists moving on a
circle), without and with self-collision avoidance, and the same on rio-sim's G1 (29 joints, 330 geom
pairs) when rio-sim is installed. The reference, measured in the same run, is the arm IK every joint-space
teleop already runs per cycle (`MinkSolver`, the 6-joint test arm, 10 iterations warm-started, tool on a
circle). Figures are per-solve times, p50 / p99 in ms, and each one's ratio to the reference's p50; a 50 Hz
loop has 20 ms.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from rio.fakes.arms import SIX_DOF_MJCF
from rio.fakes.hands import five_finger_hand_description
from rio.fakes.humanoid import upper_body_description
from rio.fakes.teleop import synthetic_hand_keypoints
from rio.kinematics import HandRetargeter, MinkSolver, MultiFrameIK


def _times(step: Callable[[int], Any], n: int) -> np.ndarray:
    out = np.empty(n)
    for i in range(n):
        t0 = time.perf_counter()
        step(i)
        out[i] = time.perf_counter() - t0
    return out * 1e3


def arm_reference(n: int) -> np.ndarray:
    ik = MinkSolver(SIX_DOF_MJCF, "tool", damping=1e-4)
    q = np.array([0.0, 0.5, 1.2, 0.0, 1.4, 0.0])
    start = ik.fk(q)
    state = {"q": q}

    def step(i: int) -> None:
        a = 2 * np.pi * i / n
        target = start.copy()
        target[:3] += 0.05 * np.array([np.cos(a) - 1, np.sin(a), 0.0])
        state["q"] = ik.solve(target, state["q"], max_iters=10).q

    return _times(step, n)


def hand(n: int) -> np.ndarray:
    rt = HandRetargeter(five_finger_hand_description("right"))
    frames = [synthetic_hand_keypoints(curl=0.5 - 0.5 * np.cos(2 * np.pi * i / n)) for i in range(n)]
    return _times(lambda i: rt(frames[i]), n)


def g1_description() -> dict[str, Any] | None:
    """rio-sim's G1 as its humanoid node describes itself, or None without rio-sim."""
    if importlib.util.find_spec("rio_sim") is None:
        return None
    from rio_sim import g1

    return {"format": "mjcf", "xml": g1.asset_text(), "joints": list(g1.JOINTS), "frames": dict(g1.FRAMES),
            "frame_type": "site", "home": g1.home()}


def wrists(n: int, description: dict[str, Any], self_collision: bool) -> np.ndarray:
    ik = MultiFrameIK({**description, "self_collision": self_collision})
    state = {"q": np.asarray(description["home"], dtype=np.float64)}
    start = {f: ik.fk(state["q"], f) for f in ("left", "right")}

    def step(i: int) -> None:
        a = 2 * np.pi * i / n
        targets = {}
        for f, p in start.items():
            t = p.copy()
            t[:3] += 0.05 * np.array([np.cos(a) - 1, np.sin(a), 0.0])
            targets[f] = t
        state["q"] = ik.solve(targets, state["q"], max_iters=10)

    return _times(step, n)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--solves", type=int, default=300, help="solves per case")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    args = p.parse_args()
    ref = arm_reference(args.solves)
    body = upper_body_description()
    cases = {"arm IK, 6 joints (reference)": ref, "hand retarget, 20 joints": hand(args.solves),
             "humanoid wrists, 2 frames": wrists(args.solves, body, False),
             "humanoid wrists + self-collision": wrists(args.solves, body, True)}
    g1 = g1_description()
    if g1 is not None:
        cases["G1 wrists"] = wrists(args.solves, g1, False)
        cases["G1 wrists + self-collision"] = wrists(args.solves, g1, True)
    r50 = float(np.percentile(ref, 50))
    out = {name: {"p50_ms": round(float(np.percentile(t, 50)), 3), "p99_ms": round(float(np.percentile(t, 99)), 3),
                  "ratio_p50": round(float(np.percentile(t, 50)) / r50, 2)} for name, t in cases.items()}
    if args.json:
        print(json.dumps(out))
        return
    print(f"{'case':34} {'p50 ms':>8} {'p99 ms':>8} {'x ref':>6}")
    for name, f in out.items():
        print(f"{name:34} {f['p50_ms']:8.3f} {f['p99_ms']:8.3f} {f['ratio_p50']:6.2f}")


if __name__ == "__main__":
    main()
