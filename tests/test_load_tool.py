"""`tools/load.py`, the script that checks the suite against load: its exit status and counts, and the
command it runs getting Ctrl+C even when the script was started with SIGINT ignored (a `&` job of a shell
without job control), which made every SIGINT test of a load run fail."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

LOAD = Path(__file__).resolve().parents[1] / "tools" / "load.py"


def test_repeated_runs_report_every_status_and_fail_with_a_failing_one(tmp_path):
    marker = tmp_path / "runs"
    # the second of three runs fails with 3
    count = (f"import pathlib,sys; p=pathlib.Path({str(marker)!r}); n=len(p.read_text()) if p.exists() else 0; "
             "p.write_text('x'*(n+1)); sys.exit(3 if n==1 else 0)")
    out = subprocess.run([sys.executable, str(LOAD), "-n", "1", "--repeat", "3", "--", sys.executable, "-c", count],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 3, out.stderr
    assert "2 passed, 1 failed of 3 runs beside 1 spinners: 0 3 0" in out.stderr


def test_the_command_gets_sigint_even_when_the_script_ignores_it():
    def ignore_sigint() -> None:
        signal.signal(signal.SIGINT, signal.SIG_IGN)

    show = "import signal; print(signal.getsignal(signal.SIGINT) is signal.SIG_IGN)"
    out = subprocess.run([sys.executable, str(LOAD), "-n", "0", "--", sys.executable, "-c", show],
                         capture_output=True, text=True, timeout=60, preexec_fn=ignore_sigint)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"
