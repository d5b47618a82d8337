"""`python -m rio_ufactory.emulator [--model xarm7] [--host 127.0.0.1] [--backend model|sim[:ARM[@WORLD]]]
[--gripper xarm|xarm_g2|bio|lite6|robotiq|none]`: an xArm controller emulator until Ctrl-C."""

from __future__ import annotations

import argparse
import logging

from ..models import ARMS
from .controller import GRIPPERS
from .serve import serve


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog="python -m rio_ufactory.emulator", description=__doc__)
    ap.add_argument("--model", default="xarm7", choices=sorted(ARMS))
    ap.add_argument("--host", default="127.0.0.1", help="address to listen on (port 502 needs root or "
                    "net.ipv4.ip_unprivileged_port_start=0)")
    ap.add_argument("--backend", default="model", help="'model' or a rio-sim arm: sim, sim:ARM, sim:ARM@WORLD")
    ap.add_argument("--gripper", default="xarm", choices=[*GRIPPERS, "none"])
    ap.add_argument("--report-hz", type=float, default=250.0)
    ap.add_argument("-v", "--verbose", action="store_true", help="log every command the first time it is used")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO, format="%(levelname)s %(message)s")
    serve(args.model, args.host, args.backend, None if args.gripper == "none" else args.gripper, args.report_hz)


if __name__ == "__main__":
    main()
