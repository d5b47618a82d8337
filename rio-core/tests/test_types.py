"""rio-core is typed: it ships `py.typed`, mypy (settings: `[tool.mypy]` in the root pyproject.toml) finds
no error in it, and a client from `rio.connect()` is typed as its node class, so a type checker sees the
node's API and flags what is not there."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import rio

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = Path("rio-core/src/rio")

needs_mypy = pytest.mark.skipif(importlib.util.find_spec("mypy") is None,
                                reason="mypy is not installed (it is in the workspace's dev dependency group)")


def _mypy(*args: str) -> subprocess.CompletedProcess[str]:
    """mypy run from the repository root, so it reads the root pyproject.toml's `[tool.mypy]`."""
    return subprocess.run([sys.executable, "-m", "mypy", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=280)


def test_py_typed_is_shipped():
    assert (Path(rio.__file__).parent / "py.typed").is_file()


@pytest.mark.slow
@needs_mypy
def test_mypy_is_clean_on_rio_core():
    if not (ROOT / PACKAGE).is_dir():
        pytest.skip("needs the repository checkout (rio-core/src/rio)")
    result = _mypy(str(PACKAGE))
    assert result.returncode == 0, f"mypy found errors in rio-core:\n{result.stdout}{result.stderr}"


@needs_mypy
def test_client_is_typed_as_its_node_class(tmp_path):
    usage = tmp_path / "typed_usage.py"
    usage.write_text(textwrap.dedent("""\
        from rio import connect
        from rio.fakes.arms import FakeArm

        arm = connect(FakeArm, "thread", name="arm")
        q: int = arm.num_joints()
        arm.move_joints([0.0] * 6)
        arm.nonexistent()

        with connect(FakeArm, "thread", name="arm") as arm2:
            arm2.check_alive()
            n: int = arm2.num_joints()
    """))
    result = _mypy(str(usage))
    errors = [line for line in result.stdout.splitlines() if ": error:" in line]
    assert len(errors) == 1, f"expected exactly the nonexistent-attribute error:\n{result.stdout}{result.stderr}"
    assert f"{usage.name}:7:" in errors[0] and '"FakeArm" has no attribute "nonexistent"' in errors[0], errors[0]
