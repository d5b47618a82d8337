"""Run an emulator in the foreground until Ctrl-C: what `rio ufactory emulator` does."""

from __future__ import annotations

import signal
import threading

from .control_box import XArmEmulator


def serve(model: str = "xarm7", host: str = "127.0.0.1", backend: str = "model", gripper: str | None = "xarm",
          report_hz: float = 250.0) -> None:
    """Start an `XArmEmulator`, print the address to give the driver, run until interrupted."""
    emu = XArmEmulator(model, host=host, backend=backend, gripper=gripper, report_hz=report_hz).start()
    try:
        print(f"{emu.arm.label} controller emulator listening on {host} (ports 502, 30001-30003); "
              f"backend {backend}, gripper {gripper or 'none'}, version '{emu.version}'", flush=True)
        print(f"connect a driver with  ip = \"{host}\"  (xArm SDK: XArmAPI(\"{host}\")); Ctrl-C stops", flush=True)
        threading.Event().wait()
    except KeyboardInterrupt:
        print("stopping", flush=True)
    finally:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C must not cut the shutdown short
        emu.stop()
