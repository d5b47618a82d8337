"""A UFACTORY xArm controller emulator at the protocol boundary: the unmodified xArm Python SDK talks
to it over the controller's real TCP protocol (command port 502, report ports 30001-30003), and it
moves a model of the arm (or a rio-sim arm) and the gripper on its tool port.

    from rio_ufactory.emulator import XArmEmulator
    with XArmEmulator("lite6", host="127.0.0.2", gripper="lite6") as emu:
        ...  # XArmAPI("127.0.0.2") works as against a Lite 6

`rio ufactory emulator --model xarm7` runs one until Ctrl-C (`serve`).
"""

from .codes import FAULTS, Err
from .control_box import GRIPPERS, XArmEmulator
from .serve import serve

__all__ = ["FAULTS", "GRIPPERS", "Err", "XArmEmulator", "serve"]
