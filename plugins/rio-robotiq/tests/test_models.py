"""SI <-> register units: Robotiq's inverted 0..255 position (with a unit's own end counts), speed and
force bytes over each model's range, DH's per-mille position and per-cent force and speed."""

from __future__ import annotations

import pytest
from rio_robotiq.models import (
    DH_MODELS,
    ROBOTIQ_MODELS,
    byte_to_scale,
    dh_force_pct,
    dh_permille,
    dh_speed_pct,
    dh_width,
    robotiq_counts,
    robotiq_width,
    scale_to_byte,
)


def test_strokes():
    assert {k: m.stroke for k, m in ROBOTIQ_MODELS.items()} == {"2f85": 0.085, "2f140": 0.140, "hande": 0.050}
    assert {k: m.stroke for k, m in DH_MODELS.items()} == {"ag95": 0.095, "ag105": 0.145}


@pytest.mark.parametrize("model", sorted(ROBOTIQ_MODELS))
def test_robotiq_position_is_inverted_and_round_trips(model):
    stroke = ROBOTIQ_MODELS[model].stroke
    assert robotiq_counts(stroke, stroke) == 0 and robotiq_counts(0.0, stroke) == 255
    assert robotiq_counts(2 * stroke, stroke) == 0 and robotiq_counts(-1.0, stroke) == 255  # clipped
    for counts in range(256):
        assert robotiq_counts(robotiq_width(counts, stroke), stroke) == counts


def test_a_units_own_end_counts():
    # a 2F-85 that reads 3 fully open and 227 with its fingers touching
    assert robotiq_counts(0.0, 0.085, 3, 227) == 227 and robotiq_counts(0.085, 0.085, 3, 227) == 3
    assert robotiq_width(227, 0.085, 3, 227) == 0.0 and robotiq_width(230, 0.085, 3, 227) == 0.0  # past the end
    assert robotiq_width(115, 0.085, 3, 227) == pytest.approx(0.0425)


def test_speed_and_force_bytes():
    lo, hi = ROBOTIQ_MODELS["2f85"].force_range
    assert scale_to_byte(lo, lo, hi) == 0 and scale_to_byte(hi, lo, hi) == 255 and scale_to_byte(1e3, lo, hi) == 255
    assert byte_to_scale(scale_to_byte(100.0, lo, hi), lo, hi) == pytest.approx(100.0, abs=(hi - lo) / 255)


def test_dh_units():
    assert dh_permille(0.095, 0.095) == 1000 and dh_permille(0.0, 0.095) == 0  # 0 closed, 1000 open
    assert dh_width(500, 0.095) == pytest.approx(0.0475)
    assert dh_force_pct(80.0, 160.0) == 50 and dh_force_pct(1.0, 160.0) == 20 and dh_force_pct(500.0, 160.0) == 100
    assert dh_speed_pct(0.0, 0.1) == 1 and dh_speed_pct(0.05, 0.1) == 50
    with pytest.raises(ValueError):
        dh_force_pct(float("nan"), 160.0)
