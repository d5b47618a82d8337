"""GELLO calibration: how a leader's raw servo angles become the follower's joint angles.

    q_follower[i] = sign[i] * (raw[i] - offset[i])        raw: Present Position in rad (multi-turn)

An XL330 horn fits its printed part four ways, so each `offset` is a multiple of pi/2 (what GELLO's
`gello_get_offset.py` finds by trying them). `calibrate()` finds them from one reading taken with the
leader held in the layout's known pose (the follower's angles for that pose are known): the multiple
of pi/2 nearest to `raw - sign * known`. What is left over (`residual`) is how far the printed parts
are from the pose; a large one means the leader was not in the pose (or a sign is wrong). Signs come
from the layout; a second reading in another known pose (`second_raw`, `second_pose`) measures them
instead, from the direction each joint moved between the two.

The trigger: `gripper_open` is its reading released (taken in the same pose), `gripper_closed` the
reading squeezed (measured, or open + the layout's travel). The leader publishes `gripper` 0 closed
.. 1 open, which leader-follower teleop scales to the follower gripper's range.

Files: `$XDG_CONFIG_HOME/rio/calibration/gello-<layout>/<name>.json` (default `~/.config/...`), or a
.json path.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from rio.errors import RioError
from rio.machine import calibration_files as files

from .layouts import Layout, get_layout

QUARTER = math.pi / 2
#: A joint whose reading is this far (rad) from any multiple of pi/2 after the known pose is removed
#: was not held in the pose: calibration refuses it.
MAX_RESIDUAL = 0.35
#: Joints must move at least this much (rad) between two poses for their sign to be measured.
MIN_SIGN_MOTION = 0.2


class CalibrationError(RioError):
    """No calibration, or one that does not fit the leader."""


@dataclass
class GelloCalibration:
    layout: str
    name: str
    offsets: list[float]
    signs: list[int]
    gripper_open: float = 0.0
    gripper_closed: float = -0.7
    #: What calibration left over per joint (rad): for the record, not used.
    residual: list[float] = field(default_factory=list)

    def joints(self, raw: np.ndarray) -> np.ndarray:
        """Raw angles (rad) of the arm joints -> follower joint angles."""
        return np.asarray(self.signs, float) * (np.asarray(raw, float) - np.asarray(self.offsets, float))

    def raw(self, q: np.ndarray) -> np.ndarray:
        """Follower joint angles -> the raw angles the leader reads in that pose (tests, emulated arms)."""
        return np.asarray(q, float) * np.asarray(self.signs, float) + np.asarray(self.offsets, float)

    def gripper(self, raw: float) -> float:
        """Trigger reading (rad) -> 0 squeezed (closed) .. 1 released (open)."""
        span = self.gripper_closed - self.gripper_open
        if span == 0:
            return 1.0
        return float(min(max(1.0 - (raw - self.gripper_open) / span, 0.0), 1.0))

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=2)

    @classmethod
    def from_json(cls, text: str, source: str = "<json>") -> GelloCalibration:
        try:
            d = json.loads(text)
            cal = cls(str(d["layout"]), str(d["name"]), [float(x) for x in d["offsets"]], [int(s) for s in d["signs"]],
                      float(d.get("gripper_open", 0.0)), float(d.get("gripper_closed", -0.7)),
                      [float(x) for x in d.get("residual", [])])
        except (ValueError, KeyError, TypeError) as e:
            raise CalibrationError(f"GELLO calibration file {source} is not valid: {type(e).__name__}: {e}") from None
        if len(cal.offsets) != len(cal.signs) or any(s not in (1, -1) for s in cal.signs):
            raise CalibrationError(f"GELLO calibration file {source}: needs one offset and one sign (+1/-1) per joint")
        return cal

    def check(self, layout: Layout, source: str) -> GelloCalibration:
        if len(self.offsets) != layout.dof:
            raise CalibrationError(f"GELLO calibration {source} has {len(self.offsets)} joints, layout "
                                   f"'{layout.name}' has {layout.dof}")
        return self


def calibrate(layout: Layout | str, raw: np.ndarray, *, name: str = "default", gripper_raw: float | None = None,
              gripper_closed_raw: float | None = None, second_raw: np.ndarray | None = None,
              second_pose: np.ndarray | None = None, known_pose: np.ndarray | None = None) -> GelloCalibration:
    """Offsets (and signs, given a second pose) from readings of the leader held in known poses.

    `raw`: the arm joints' raw angles (rad) in the known pose (the layout's unless `known_pose`);
    `gripper_raw`: the trigger released, in that pose; `gripper_closed_raw`: squeezed (else the
    layout's travel); `second_raw` in `second_pose`: signs measured from the motion between the two."""
    lay = get_layout(layout) if isinstance(layout, str) else layout
    raw = np.asarray(raw, float)
    pose = np.asarray(lay.known_pose if known_pose is None else known_pose, float)
    if raw.shape != (lay.dof,) or pose.shape != (lay.dof,):
        raise CalibrationError(f"layout '{lay.name}' has {lay.dof} joints: got {raw.size} readings, {pose.size} pose "
                               "angles")
    signs = np.asarray(lay.signs, float)
    if second_raw is not None:
        if second_pose is None:
            raise CalibrationError("a second reading needs its pose (second_pose)")
        d_raw, d_q = np.asarray(second_raw, float) - raw, np.asarray(second_pose, float) - pose
        moved = np.abs(d_q) >= MIN_SIGN_MOTION
        measured = np.sign(d_raw * d_q)
        disagree = moved & (np.abs(np.abs(d_raw) - np.abs(d_q)) > MAX_RESIDUAL)
        if disagree.any():
            bad = [f"joint{i + 1}" for i in np.flatnonzero(disagree)]
            raise CalibrationError(f"{', '.join(bad)}: moved {np.abs(d_raw)[disagree].round(2).tolist()} rad "
                                   f"between the two poses, which differ by {np.abs(d_q)[disagree].round(2).tolist()}: "
                                   "hold the leader in each pose")
        signs = np.where(moved, measured, signs)
    target = raw - signs * pose
    offsets = np.round(target / QUARTER) * QUARTER
    residual = target - offsets
    far = np.abs(residual) > MAX_RESIDUAL
    if far.any():
        bad = ", ".join(f"joint{i + 1} ({residual[i]:+.2f} rad)" for i in np.flatnonzero(far))
        raise CalibrationError(f"the leader is not in the known pose {np.round(pose, 3).tolist()}: {bad} off a "
                               f"multiple of pi/2; hold it in that pose (check layout '{lay.name}'s joint signs)")
    g_open = float(gripper_raw) if gripper_raw is not None else 0.0
    g_closed = float(gripper_closed_raw) if gripper_closed_raw is not None else g_open + lay.gripper_travel
    return GelloCalibration(lay.name, name, offsets.tolist(), [int(s) for s in signs], g_open, g_closed,
                            residual.round(4).tolist())


# -- files ------------------------------------------------------------------------------------------
def calibration_path(name: str, layout: str) -> Path:
    """A name -> its file in the config directory (`rio.machine.calibration_files`); a path as given."""
    return files.calibration_path(name, f"gello-{layout}")


def save_calibration(cal: GelloCalibration, path: Path | None = None) -> Path:
    return files.save_text(path or calibration_path(cal.name, cal.layout), cal.to_json() + "\n")


def load_calibration(name: str, layout: Layout, port: str = "PORT") -> GelloCalibration:
    path = calibration_path(name, layout.name)
    if not path.is_file():
        raise CalibrationError(f"no GELLO calibration '{name}' for layout '{layout.name}' ({path} does not exist); "
                               f"hold the leader in the known pose {[round(x, 3) for x in layout.known_pose]} and run "
                               f"`rio gello calibrate --port {port} --layout {layout.name} --name {name}`")
    return GelloCalibration.from_json(path.read_text(encoding="utf-8"), str(path)).check(layout, str(path))
