"""On a machine without Debian's libusb (a fresh `uv sync` on a bare Debian), this plugin's tests still
pass: each one that needs pyrealsense2 skips, naming the package to install, where it used to stop the
whole run with a collection error (pyrealsense2's extension links libusb-1.0.so.0, so importing it
raises ImportError, which `pytest.importorskip` does not skip).

Where libusb is installed (CI installs it) it is hidden from a pytest subprocess (`rio.machine.hide_libraries`:
the child's dynamic loader is refused the library), so `import pyrealsense2` fails there exactly as on
a bare machine; where it is not, the subprocess runs as it is.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from rio_realsense.doctor import LIBUSB

from rio.machine.hide_libraries import C_COMPILER, hide_libraries_env
from rio.testing import skip_tests_without

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]  # the repository: its pytest settings (import mode, markers) apply to the run
LOADER_ERROR = "ImportError: libusb-1.0.so.0: cannot open shared object file: No such file or directory"
#: The modules with tests that import pyrealsense2 (test_hardware's are deselected: marked `hardware`). A new one
#: that forgets the skip errors the collection, which the exit status below catches.
NEEDING = {"test_conformance.py", "test_listing.py", "test_reconnect.py", "test_recording.py", "test_select.py",
           "test_software_frames.py", "test_plugin.py"}


def _bare_env(tmp_path: Path) -> dict[str, str]:
    """This environment, with libusb hidden unless it is missing already."""
    if LIBUSB.problem() is not None:
        return dict(os.environ)
    skip_tests_without(C_COMPILER)
    return hide_libraries_env([LIBUSB.library], tmp_path)


@pytest.mark.slow
def test_without_libusb_every_test_that_needs_it_skips_naming_the_package(tmp_path):
    env = _bare_env(tmp_path)
    probe = subprocess.run([sys.executable, "-c", "import pyrealsense2"], env=env, capture_output=True, text=True,
                           timeout=120)
    assert probe.returncode == 1 and LOADER_ERROR in probe.stderr, probe.stderr[-2000:]  # as on a bare machine

    run = subprocess.run([sys.executable, "-m", "pytest", str(HERE), f"--ignore={__file__}", "-p", "no:cacheprovider",
                          "-n", "0", "-rs", "-q"], cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    out = run.stdout + run.stderr
    assert run.returncode in (0, 5), out[-4000:]
    reason = "needs Debian package libusb-1.0-0 (apt install libusb-1.0-0)"
    skipped = {m.group(1) for m in re.finditer(r"^SKIPPED \[\d+\] \S*?(test_\w+\.py):\d+: (.*)$", out, re.M)
               if reason in m.group(2) and "libusb-1.0.so.0: cannot open shared object file" in m.group(2)}
    assert skipped == NEEDING, out[-4000:]
    assert re.search(r"\d+ passed", out) and "error" not in out.splitlines()[-1], out[-4000:]
