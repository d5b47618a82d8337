"""`rio doctor`: what this machine can run. Checks modules with `importlib.util.find_spec` only, so a
broken or slow vendor SDK is never imported just to be listed."""

from __future__ import annotations

import platform
import sys
from typing import Annotated

import typer

# (import name, distribution to install, what needs it)
VENDOR_SDKS = [
    ("scservo_sdk", "feetech-servo-sdk", "Feetech servo bus (SO-100/SO-101)"),
    ("dynamixel_sdk", "dynamixel-sdk", "Dynamixel servo bus (Koch, ALOHA)"),
    ("xarm", "xarm-python-sdk", "UFactory xArm"),
    ("rtde_control", "ur-rtde", "Universal Robots (RTDE)"),
    ("franky", "franky-control", "Franka (franky)"),
    ("piper_sdk", "piper-sdk", "AgileX PiPER"),
    ("can", "python-can", "CAN bus devices"),
    ("unitree_sdk2py", "unitree-sdk2py-dimos", "Unitree G1/H1 (DDS)"),
    ("pyrealsense2", "pyrealsense2", "Intel RealSense cameras"),
    ("pyspacemouse", "pyspacemouse", "3Dconnexion SpaceMouse teleop"),
    ("mujoco", "mujoco", "simulation (rio-sim)"),
    ("av", "av", "video encoding for recording"),
    ("lerobot", "lerobot", "LeRobot datasets and policies"),
    ("openpi_client", "openpi-client", "openpi policy servers"),
    ("onnxruntime", "onnxruntime", "ONNX policies"),
    ("torch", "torch", "PyTorch policies"),
]

# middleware name -> (import name or None, install command)
MIDDLEWARE_DEPS = {
    "thread": (None, ""),
    "shm": (None, ""),
    "zmq": ("zmq", "pip install pyzmq"),
    "zenoh": ("zenoh", "pip install 'rio-core[zenoh]'"),
    "portal": ("portal", "pip install 'rio-core[portal]'"),
}

EXTRAS = [("copier", "pip install 'rio-core[new]'", "`rio new plugin` templates")]


def found(module: str) -> bool:
    import importlib.util

    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        return False


def doctor(as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output.")] = False) -> None:
    """Python version, plugins found, vendor SDKs and middleware dependencies present."""
    from .. import __version__
    from ..plugins import get_registry
    from .output import console, print_json, table, warn_problems

    reg = get_registry()
    reg.all_specs()
    middlewares = {s.name: s for s in reg.specs("rio_middlewares")}
    mw_rows = []
    for name, spec in middlewares.items():
        module, install = MIDDLEWARE_DEPS.get(name, (None, ""))
        dep_ok = module is None or found(module)
        # the implementing module itself (find_spec imports only its parent packages)
        impl_ok = found(spec.target.partition(":")[0])
        why = install if not dep_ok else ("" if impl_ok else f"{spec.target} not found (plugin {spec.plugin})")
        mw_rows.append({"middleware": name, "plugin": spec.plugin, "dependency": module or "-",
                        "ok": dep_ok and impl_ok, "install": why})
    sdk_rows = [{"module": m, "distribution": d, "for": what, "ok": found(m), "install": f"pip install {d}"}
                for m, d, what in VENDOR_SDKS]
    extra_rows = [{"module": m, "for": what, "ok": found(m), "install": cmd} for m, cmd, what in EXTRAS]
    info = {"python": sys.version.split()[0], "platform": platform.platform(), "rio": __version__,
            "executable": sys.executable}
    if as_json:
        print_json({**info, "plugins": [{"name": p.dist, "version": p.version} for p in reg.plugins.values()],
                    "problems": [str(p) for p in reg.problems], "middlewares": mw_rows, "sdks": sdk_rows,
                    "extras": extra_rows})
        return
    out = console()
    out.print(f"rio {info['rio']} on Python {info['python']} ({info['platform']})\n{info['executable']}", markup=False)
    table("plugins", ("plugin", "version"), [(p.dist, p.version) for p in reg.plugins.values()])
    from rich.text import Text

    mark = {True: Text("yes", style="green"), False: Text("no", style="red")}
    table("middlewares", ("middleware", "needs", "present", "to install"),
          [(r["middleware"], r["dependency"], mark[r["ok"]], r["install"]) for r in mw_rows])
    table("vendor SDKs", ("module", "for", "present", "to install"),
          [(r["module"], r["for"], mark[r["ok"]], "" if r["ok"] else r["install"]) for r in sdk_rows])
    table("optional tools", ("module", "for", "present", "to install"),
          [(r["module"], r["for"], mark[r["ok"]], "" if r["ok"] else r["install"]) for r in extra_rows])
    warn_problems(reg)
