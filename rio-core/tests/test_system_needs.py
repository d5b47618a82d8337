"""What the operating system must provide (`rio.machine.system_needs.SystemNeed`), the skips that name its Debian
package (`rio.testing.skip_tests_without`), and hiding a library from a child process the way a bare
machine lacks it (`rio.machine.hide_libraries`)."""

from __future__ import annotations

import ctypes
import os
import stat
import subprocess
import sys
from types import SimpleNamespace

import pytest

from rio.machine import netns
from rio.machine.hide_libraries import C_COMPILER, hide_libraries_env
from rio.machine.system_needs import SystemNeed
from rio.testing import skip_tests_without

linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="sonames and LD_AUDIT are Linux (glibc)")
NO_FILE = "cannot open shared object file: No such file or directory"


@linux
def test_a_missing_library_names_its_package_and_the_loaders_error():
    need = SystemNeed("libfoo0", library="libfoo-rio-test.so.0", purpose="the foo driver")
    assert need.missing() == (f"needs Debian package libfoo0 (apt install libfoo0) for the foo driver: "
                              f"libfoo-rio-test.so.0: {NO_FILE}")
    assert SystemNeed("libc6", library="libc.so.6").missing() is None


def test_a_missing_program_and_a_failing_probe(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))
    need = SystemNeed("iproute2", program="ip")
    assert need.missing() == "needs Debian package iproute2 (apt install iproute2): no `ip` on PATH"
    ip = tmp_path / "ip"
    ip.write_text("#!/bin/sh\n")
    ip.chmod(ip.stat().st_mode | stat.S_IXUSR)
    assert need.missing() is None
    problem: list[str | None] = ["no EGL display"]
    gl = SystemNeed("libegl1 libgl1-mesa-dri", probe=lambda: problem[0])
    assert gl.missing() == ("needs Debian packages libegl1, libgl1-mesa-dri (apt install libegl1 libgl1-mesa-dri): "
                            "no EGL display")
    problem[0] = None
    assert gl.missing() is None


def test_skip_tests_without_skips_now_or_marks_the_tests_under_a_path(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))
    need = SystemNeed("iproute2", program="ip")
    with pytest.raises(pytest.skip.Exception, match=r"^needs Debian package iproute2 \(apt install iproute2\): "
                                                    r"no `ip` on PATH \(the namespace tests\)$"):
        skip_tests_without(need, "the namespace tests")
    with pytest.raises(pytest.skip.Exception, match=r"^rio_no_such_sdk is not installed \(no wheels here\)$"):
        skip_tests_without("rio_no_such_sdk", "no wheels here")
    skip_tests_without("pytest")  # present: nothing happens

    marked: dict[str, list] = {}
    items = [SimpleNamespace(path=f"/r/plugins/{p}/tests/test_x.py", add_marker=lambda m, p=p: marked.setdefault(p, [])
                             .append(m)) for p in ("rio-acme", "rio-other")]
    skip_tests_without(need, "", items, "rio-acme")
    assert list(marked) == ["rio-acme"]
    assert marked["rio-acme"][0].kwargs["reason"].startswith("needs Debian package iproute2 (apt install iproute2)")


@linux
def test_network_namespaces_without_ip_name_iproute2(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))
    assert netns.available() == "needs Debian package iproute2 (apt install iproute2): no `ip` on PATH"


def _load(soname: str, env: dict[str, str] | None = None) -> str:
    """'ok', or the error of loading `soname` in a fresh interpreter with `env`."""
    code = f"import ctypes\ntry:\n    ctypes.CDLL({soname!r})\n    print('ok')\nexcept OSError as e:\n    print(e)"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout.strip()


@linux
def test_a_hidden_library_fails_to_load_in_the_child_as_if_absent(tmp_path):
    skip_tests_without(C_COMPILER)
    hidden, other = "libBrokenLocale.so.1", "libanl.so.1"  # both glibc's own, and never loaded by Python itself
    for soname in (hidden, other):
        try:
            ctypes.CDLL(soname)
        except OSError as e:
            pytest.skip(f"this C library has no {soname}: {e}")
    env = hide_libraries_env([hidden], tmp_path, env={**os.environ, "LD_LIBRARY_PATH": "/usr/lib:/lib"})
    assert _load(hidden, env) == f"{hidden}: {NO_FILE}"  # through LD_LIBRARY_PATH, the cache and the default paths
    assert _load(other, env) == "ok"
    assert _load(hidden) == "ok"  # this process and its other children are left alone
    if _load("libBrokenLocale.so") == "ok":  # the development link, where libc6-dev is installed
        assert _load("libBrokenLocale.so", env) == f"libBrokenLocale.so: {NO_FILE}"
    again = hide_libraries_env([other], tmp_path, env=env)  # a second hide adds to the first
    assert _load(hidden, again).endswith(NO_FILE) and _load(other, again).endswith(NO_FILE)
    assert again["LD_AUDIT"] == env["LD_AUDIT"]  # the audit library once
    with pytest.raises(ValueError, match="sonames"):
        hide_libraries_env(["/usr/lib/libanl.so.1"], tmp_path)
