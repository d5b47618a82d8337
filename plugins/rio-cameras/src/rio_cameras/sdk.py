"""Vendor SDKs are imported only when a camera is opened (listing drivers or loading a station must work
without them), and a missing one is an ImportError that says how to get it."""

from __future__ import annotations

import importlib
from typing import Any


def require(module: str, driver: str, how: str) -> Any:
    """Import `module` for `driver`, or raise ImportError naming the driver and the install step `how`."""
    try:
        return importlib.import_module(module)
    except ImportError as e:
        raise ImportError(f"{driver} needs the Python module '{module}', which is not importable ({e}). "
                          f"{how}") from e


OAK_HINT = "Install it with: pip install 'rio-cameras[oak]'"
RECORD3D_HINT = ("Install it with: pip install 'rio-cameras[record3d]' (on Linux it needs libusbmuxd: "
                 "sudo apt install libusbmuxd-dev)")
#: The one-line install step `rio doctor` shows.
ZED_INSTALL = "the ZED SDK installer (stereolabs.com), then its get_python_api.py"
ZED_HINT = ("pyzed is not on PyPI: it comes with the Stereolabs ZED SDK (NVIDIA GPU and CUDA required). "
            "Install the SDK from https://www.stereolabs.com/developers/release, then run "
            "`python /usr/local/zed/get_python_api.py` with this environment's python "
            "(Windows: C:\\Program Files (x86)\\ZED SDK\\get_python_api.py).")
