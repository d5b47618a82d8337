"""The published reach in each arm plugin's model table agrees with the reach computed on the model.

Without the solver (a plugin installed without its `[ik]` extra) an arm's workspace box is the table's
reach plus 25% around the shoulder (`rio.kinematics.reach.reach_box_from_table`); with it, the box computed
by forward kinematics of the joints. The two must agree: the table's box holds every tool position the
joints reach (a box that cut into the real workspace would stop the arm short of places it can go), and the
farthest the flange gets from the base's axis is within -10%/+20% of the published figure (vendors measure
their reach to the wrist; the flange sticks out past it). A wrong or swapped entry fails here."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

from rio.kinematics.reach import reach_box, reach_box_from_table

pytest.importorskip("mink")

from rio.kinematics import solver_from_description  # noqa: E402

DRIVERS = {"rio_ufactory": "rio_ufactory.arm.driver", "rio_ur": "rio_ur.arm.driver",
           "rio_franka": "rio_franka.arm.driver", "rio_kinova": "rio_kinova.arm.driver"}


def tables():
    out = []
    for plugin, module in DRIVERS.items():
        try:
            models = importlib.import_module(module).MODELS
        except ImportError:  # the plugin is not installed here
            continue
        out += [pytest.param(models, name, id=f"{plugin}.{name}") for name in models.models]
    return out


@pytest.mark.parametrize(("models", "name"), tables())
def test_the_published_reach_agrees_with_the_model(models, name):
    reach, shoulder = models.reach(name)
    desc = models.describe(name)
    solver = solver_from_description(desc, orientation_cost=1.0, damping=1e-4)
    lower, upper = reach_box(solver, desc.get("home"), margin=0.0)
    t_lower, t_upper = reach_box_from_table(reach, shoulder)
    assert (lower >= t_lower).all() and (upper <= t_upper).all(), (
        f"{name}: the joints reach {lower.round(3)}..{upper.round(3)}, beyond the table's box "
        f"{t_lower.round(3)}..{t_upper.round(3)} (reach {reach} m, shoulder {shoulder} m)")
    horizontal = float(np.abs(np.concatenate([lower[:2], upper[:2]])).max())
    assert 0.9 * reach <= horizontal <= 1.2 * reach, f"{name}: the flange reaches {horizontal:.3f} m, published {reach}"
    assert models.ik_extra and models.ik_extra.endswith("[ik]")
