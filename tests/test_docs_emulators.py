"""docs/emulators.md's CAN example runs as the page prints it: a motor emulator on python-can's virtual bus
answers the driver's frames and moves to the goal (the page says this test keeps it honest)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

PAGE = Path(__file__).resolve().parent.parent / "docs" / "emulators.md"


def test_the_can_emulator_example_runs():
    pytest.importorskip("can", reason="python-can is not installed (the dev environment has it)")
    blocks = re.findall(r"```python\n(.*?)```", PAGE.read_text(encoding="utf-8"), re.S)
    example = next(b for b in blocks if "class CanMotor" in b)
    scope: dict = {"__name__": "docs_example"}
    exec(compile(example, str(PAGE), "exec"), scope)  # asserts the motor reached its goal
    assert abs(scope["motor"].position_deg - 30.0) < 0.5


def test_the_example_fails_when_the_motor_does_not_answer():
    """The example's driver side is not a test that cannot fail: with the motor's replies going to another
    id, `go_to` times out."""
    pytest.importorskip("can", reason="python-can is not installed (the dev environment has it)")
    blocks = re.findall(r"```python\n(.*?)```", PAGE.read_text(encoding="utf-8"), re.S)
    example = next(b for b in blocks if "class CanMotor" in b).replace("arbitration_id=0x240 + self.id",
                                                                       "arbitration_id=0x340 + self.id")
    with pytest.raises(TimeoutError, match="did not answer"):
        exec(compile(example, str(PAGE), "exec"), {"__name__": "docs_example"})
