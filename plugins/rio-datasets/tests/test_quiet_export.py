"""An export is quiet when all is well: SVT-AV1's own settings and advice (two dozen `Svt[info]`/`Svt[warn]`
lines per export) stay out of the user's terminal, unless they ask for them with SVT_LOG."""

from __future__ import annotations

import os
import subprocess
import sys


def _export(native, out, **env) -> subprocess.CompletedProcess:
    environ = {k: v for k, v in os.environ.items() if k != "SVT_LOG"}
    return subprocess.run([sys.executable, "-m", "rio", "export", str(native), str(out), "--format", "lerobot"],
                          capture_output=True, text=True, timeout=240, env={**environ, **env})


def test_an_av1_export_prints_no_encoder_chatter(native, tmp_path):
    r = _export(native, tmp_path / "quiet")
    assert r.returncode == 0, r.stderr[-2000:]
    assert "Svt[" not in r.stdout + r.stderr, r.stderr[-2000:]
    loud = _export(native, tmp_path / "loud", SVT_LOG="3")  # the user's own choice wins
    assert loud.returncode == 0 and "Svt[info]" in loud.stderr
