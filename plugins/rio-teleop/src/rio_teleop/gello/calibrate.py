"""The calibration procedure on a bus, apart from terminal I/O (`rio gello calibrate` and the tests
run the same steps): open the leader, torque off, read it held in the known pose (the average of a
few Sync Reads), optionally the trigger squeezed and a second pose, and compute the calibration."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from . import control_table as T
from .bus import DynamixelBus
from .calibration import GelloCalibration, calibrate
from .layouts import Layout, get_layout


def read_raw(bus: DynamixelBus, ids: tuple[int, ...], samples: int = 10) -> np.ndarray:
    """Raw angles (rad) of `ids`, averaged over `samples` Sync Reads."""
    return np.mean([bus.read_state(ids)[0] for _ in range(max(1, samples))], axis=0)


def calibrate_leader(port: str, layout: Layout | str, *, name: str = "default", baudrate: int = 57600,
                     wait: Callable[[str], None] = lambda step: None, squeeze: bool = False,
                     second_pose: Sequence[float] | None = None, label: str | None = None) -> GelloCalibration:
    """`wait(step)` returns once the person did `step` ("known pose", "squeeze", "second pose")."""
    lay = get_layout(layout) if isinstance(layout, str) else layout
    ids = lay.ids
    with DynamixelBus(port, baudrate=baudrate, names=lay.servo_names(), label=label) as bus:
        bus.check_present(ids)
        for sid in ids:
            bus.write(sid, T.TORQUE_ENABLE, 0)
        wait("known pose")
        raw = read_raw(bus, ids)
        closed = second = None
        if squeeze and lay.gripper_id is not None:
            wait("squeeze")
            closed = float(read_raw(bus, ids)[-1])
        if second_pose is not None:
            wait("second pose")
            second = read_raw(bus, ids)[:lay.dof]
    grip = float(raw[lay.dof]) if lay.gripper_id is not None else None
    return calibrate(lay, raw[:lay.dof], name=name, gripper_raw=grip, gripper_closed_raw=closed, second_raw=second,
                     second_pose=None if second_pose is None else np.asarray(second_pose, float))
