#!/usr/bin/env python3
"""Run a command on a loaded machine: N (default 2) CPU-bound processes spin beside it and are stopped
when it ends; the exit status is the command's.

Why: CI and the 2-core development machines run the suite beside other work, and failures that only show
there (an emulator thread descheduled for 100 ms, a state gap, a loop that integrated a stall) do not
reproduce on a quiet machine. This puts the load back on purpose, so a fix can be checked against it.

    tools/load.py -- uv run --no-sync pytest plugins/rio-ur/tests/test_station.py -q -x
    tools/load.py -n 4 --repeat 5 -- .venv/bin/python -m pytest plugins/rio-ufactory/tests/test_emulator.py -q

`--repeat K` runs the command K times under the same load and prints the pass/fail count; the exit
status is then 0 only when every run passed (else the last failing run's status). Spinners stop with
this process even when it is killed without a chance to clean up: each one exits once its parent is
gone. Standard library only, so it runs before `uv sync`.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time

#: The spinner: burn CPU until told to stop, or until the process that started it is gone (checked
#: every few milliseconds of work, so an orphan lives for a moment at most).
SPIN = """
import os
parent = os.getppid()
while os.getppid() == parent:
    for _ in range(200_000):
        pass
"""


def start_spinners(n: int, nice: int) -> list[subprocess.Popen]:
    def lower_priority() -> None:
        if nice:
            os.nice(nice)

    return [subprocess.Popen([sys.executable, "-c", SPIN], preexec_fn=lower_priority, stdin=subprocess.DEVNULL)
            for _ in range(n)]


def stop_spinners(spinners: list[subprocess.Popen]) -> None:
    for p in spinners:
        if p.poll() is None:
            p.terminate()
    for p in spinners:
        try:
            p.wait(timeout=5)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def run_once(command: list[str]) -> int:
    """The command's exit status; a signal sent to this process (Ctrl+C, a CI timeout's SIGTERM) is
    passed on to the command, whose status then counts as usual. The command gets SIGINT's default action
    even when this script was started with it ignored (`&` in a script: POSIX has background jobs ignore
    SIGINT when job control is off), or every test of Ctrl+C in the suite would fail."""
    proc = subprocess.Popen(command, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    forwarded = {}

    def forward(signum, _frame):
        proc.send_signal(signum)

    for sig in (signal.SIGINT, signal.SIGTERM):
        forwarded[sig] = signal.signal(sig, forward)
    try:
        rc = proc.wait()
        return 128 - rc if rc < 0 else rc  # killed by a signal: the shell's convention
    finally:
        for sig, old in forwarded.items():
            signal.signal(sig, old)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 usage="%(prog)s [-n N] [--repeat K] [--nice NICE] -- command [args...]")
    ap.add_argument("-n", "--spinners", type=int, default=2, help="CPU-bound processes beside the command (2)")
    ap.add_argument("--repeat", type=int, default=1, help="run the command this many times under the load (1)")
    ap.add_argument("--nice", type=int, default=0,
                    help="niceness of the spinners (0: they compete with the command as equals)")
    ap.add_argument("command", nargs=argparse.REMAINDER)
    args = ap.parse_args(argv)
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not command:
        ap.error("no command given (put it after --)")
    if args.spinners < 0 or args.repeat < 1:
        ap.error("-n must be >= 0 and --repeat >= 1")
    spinners = start_spinners(args.spinners, args.nice)
    statuses: list[int] = []
    try:
        for i in range(args.repeat):
            t0 = time.monotonic()
            rc = run_once(command)
            statuses.append(rc)
            if args.repeat > 1:
                print(f"[load.py] run {i + 1}/{args.repeat}: exit {rc} ({time.monotonic() - t0:.1f} s) "
                      f"beside {args.spinners} spinners", file=sys.stderr, flush=True)
    finally:
        stop_spinners(spinners)
    failed = [rc for rc in statuses if rc != 0]
    if args.repeat > 1:
        print(f"[load.py] {len(statuses) - len(failed)} passed, {len(failed)} failed of {len(statuses)} runs "
              f"beside {args.spinners} spinners: {' '.join(map(str, statuses))}", file=sys.stderr, flush=True)
    return failed[-1] if failed else 0


if __name__ == "__main__":
    sys.exit(main())
