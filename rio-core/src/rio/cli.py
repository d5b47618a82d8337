"""The `rio` command line (grows with the plugin issue: plugins, stations, doctor, new, bench)."""

from __future__ import annotations

import sys


def main(argv: list[str] | None = None) -> int:
    from . import __version__

    args = sys.argv[1:] if argv is None else argv
    if args[:1] == ["--version"]:
        print(f"rio {__version__}")
        return 0
    print("usage: rio --version", file=sys.stderr)
    return 2
