"""What the driver contract costs per cycle: a kind's `cycle()` (read, commander step, write, the
standard keys; for an arm with a model also forward kinematics) against the same driver's bare
`read_joints()` + `write_joints()`, measured in the same run, interleaved in rounds.

    uv run python bench/driver_cycle.py [--cycles 20000] [--rounds 5]

A 500 Hz loop has 2000 us per cycle: the figures say how much of it the contract takes.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from rio import clock
from rio.fakes.arms import FakeArm, FakeModelArm
from rio.testing import lifecycle


def per_cycle_us(fn, cycles: int) -> float:
    t0 = time.perf_counter()
    for _ in range(cycles):
        fn()
    return (time.perf_counter() - t0) / cycles * 1e6


def measure(node, cycles: int, rounds: int) -> tuple[float, float]:
    """(contract, bare) median microseconds per cycle."""
    with lifecycle(node):
        node.command_joints(np.full(node.dof, 0.3), clock.now() + 1e6)  # a long move: the commander works

        def bare() -> None:
            node.read_joints()
            node.write_joints(node.commander.goal)

        contract, reference = [], []
        for _ in range(rounds):
            reference.append(per_cycle_us(bare, cycles))
            contract.append(per_cycle_us(node.cycle, cycles))
    return float(np.median(contract)), float(np.median(reference))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=20000)
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    rows = [("arm, joint commander", FakeArm(dof=6, max_step_rad=1e-4))]
    try:
        import mink  # noqa: F401

        rows.append(("arm + FK from robot_description()", FakeModelArm(max_step_rad=1e-4)))
    except ImportError:
        print("(mink not installed: the FK row is skipped; pip install 'rio-core[ik]')")
    print(f"{'driver':38s} {'contract us':>12s} {'bare us':>9s} {'ratio':>7s} {'of a 500 Hz cycle':>18s}")
    for label, node in rows:
        contract, bare = measure(node, args.cycles, args.rounds)
        print(f"{label:38s} {contract:12.1f} {bare:9.1f} {contract / bare:7.1f} {contract / 2000:17.1%}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
