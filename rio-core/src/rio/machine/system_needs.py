"""What the operating system must provide and no wheel can bring: a shared library or a program from a
Debian package.

The module that uses one declares it as a `SystemNeed`; `rio doctor` can show it, and its tests skip with
it (`rio.testing.skip_tests_without`), naming the package, so the test suite passes on a bare machine and
says what to `apt install` to run the rest.
"""

from __future__ import annotations

import shutil
import sys
from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True)
class SystemNeed:
    """A shared library or program that the operating system must provide, and the Debian package(s)
    (`package`, space separated) that do. Give what proves it is there: `library`, a soname looked up
    as the dynamic loader does when a binary wheel's extension or a ctypes load asks for it (Linux
    only: elsewhere the wheel brings or finds its own); `program`, a command on PATH; or `probe`, a
    function returning None when usable, else the problem (for what no single file proves, such as a
    working OpenGL). `purpose` says in a few words what needs it."""

    package: str
    library: str | None = None
    program: str | None = None
    probe: Callable[[], str | None] | None = None
    purpose: str = ""

    def problem(self) -> str | None:
        """What is missing here, as the system says it (the loader's error, a program not on PATH), or None."""
        if self.library is not None and sys.platform.startswith("linux"):
            import ctypes

            try:
                ctypes.CDLL(self.library)
            except OSError as e:  # the loader's own words: "libusb-1.0.so.0: cannot open shared object file: ..."
                return str(e)
        if self.program is not None and shutil.which(self.program) is None:
            return f"no `{self.program}` on PATH"
        return self.probe() if self.probe is not None else None

    def missing(self) -> str | None:
        """None when present, else one line naming the package(s) to install, what needs them and what is
        missing: "needs Debian package libusb-1.0-0 (apt install libusb-1.0-0) for ...: libusb-1.0.so.0:
        cannot open shared object file: No such file or directory"."""
        problem = self.problem()
        if problem is None:
            return None
        names = self.package.split()
        plural = "s" if len(names) > 1 else ""
        purpose = f" for {self.purpose}" if self.purpose else ""
        return f"needs Debian package{plural} {', '.join(names)} (apt install {' '.join(names)}){purpose}: {problem}"
