"""Per-arm calibration: how encoder steps map to joint radians, kept apart from driver logic.

A calibration file describes one physical arm (follower or leader, all six servos) as JSON:

    {"model": "so100", "device": "follower", "name": "left",
     "joints": {"shoulder_pan": {"id": 1, "homing_offset": -312, "zero": 2048,
                                 "range_min": 910, "range_max": 3180, "sign": 1}, ...}}

`homing_offset` is written into each servo (it reports `encoder - homing_offset`), chosen so the
arm's middle pose reads mid-turn: every joint's range then lies inside 0..4095 and never crosses the
encoder's wrap, which a position servo cannot cross. `zero` is the reading that means 0 rad (the
middle pose), `range_min..range_max` the reachable readings (they become the servo's own position
limits and the drivers' joint limits), `sign` flips a joint's direction. Leader and follower
calibrated in the same middle pose report the same radians for the same pose.

Files live in `$XDG_CONFIG_HOME/rio/calibration/<model>-<device>/<name>.json` (default
`~/.config/...`). An emulated bus without a file gets `default_calibration()`.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

from rio.machine import calibration_files as files

from .errors import CalibrationError
from .feetech import control_table as T
from .models import ARM_IDS, ARM_JOINTS, GRIPPER, GRIPPER_ID

MID = T.STEPS_PER_TURN // 2
RAD_PER_STEP = 2 * math.pi / T.STEPS_PER_TURN
DEVICES = ("follower", "leader")


@dataclass
class JointCalibration:
    id: int
    homing_offset: int = 0
    zero: int = MID
    range_min: int = 0
    range_max: int = T.STEPS_PER_TURN - 1
    sign: int = 1

    def to_rad(self, steps: float) -> float:
        return self.sign * (steps - self.zero) * RAD_PER_STEP

    def to_steps(self, rad: float) -> int:
        """Joint angle -> goal register value, inside the calibrated range."""
        steps = round(self.zero + self.sign * rad / RAD_PER_STEP)
        return int(min(max(steps, self.range_min), self.range_max))

    def limits_rad(self) -> tuple[float, float]:
        a, b = self.to_rad(self.range_min), self.to_rad(self.range_max)
        return (a, b) if a <= b else (b, a)

    def fraction(self, steps: float) -> float:
        """0 at range_min (jaw closed) .. 1 at range_max (open)."""
        span = self.range_max - self.range_min
        return min(max((steps - self.range_min) / span, 0.0), 1.0) if span else 0.0

    def from_fraction(self, frac: float) -> int:
        return int(round(self.range_min + min(max(frac, 0.0), 1.0) * (self.range_max - self.range_min)))


@dataclass
class ArmCalibration:
    model: str
    device: str
    name: str
    joints: dict[str, JointCalibration] = field(default_factory=dict)

    def joint(self, name: str) -> JointCalibration:
        if name not in self.joints:
            raise CalibrationError(f"calibration '{self.name}' ({self.model} {self.device}) has no joint '{name}'; "
                                   f"it has {sorted(self.joints)}")
        return self.joints[name]

    def by_id(self) -> dict[int, JointCalibration]:
        return {j.id: j for j in self.joints.values()}

    def to_json(self) -> str:
        return json.dumps({"model": self.model, "device": self.device, "name": self.name,
                           "joints": {k: asdict(v) for k, v in self.joints.items()}}, indent=2)

    @classmethod
    def from_json(cls, text: str, source: str = "<json>") -> ArmCalibration:
        try:
            data = json.loads(text)
            joints = {k: JointCalibration(**{f: int(v) for f, v in j.items()}) for k, j in data["joints"].items()}
            return cls(str(data["model"]), str(data.get("device", data.get("role"))), str(data["name"]), joints)
        except (ValueError, KeyError, TypeError) as e:
            raise CalibrationError(f"calibration file {source} is not valid: {type(e).__name__}: {e}") from None


def calibration_path(name: str, model: str, device: str) -> Path:
    """A name -> its file in the config directory (`rio.machine.calibration_files`); a path as given."""
    return files.calibration_path(name, f"{model}-{device}")


def save_calibration(cal: ArmCalibration, path: Path | None = None) -> Path:
    return files.save_text(path or calibration_path(cal.name, cal.model, cal.device), cal.to_json() + "\n")


def default_calibration(model: str, device: str, name: str = "emulator") -> ArmCalibration:
    """What a fresh emulated arm uses: offsets 0, mid-turn is 0 rad, ranges like a real SO-arm's."""
    half = {"shoulder_pan": 110, "shoulder_lift": 100, "elbow_flex": 100, "wrist_flex": 100, "wrist_roll": 160}
    joints = {}
    for name_, sid in zip(ARM_JOINTS, ARM_IDS, strict=True):
        h = round(half[name_] / 360 * T.STEPS_PER_TURN)
        joints[name_] = JointCalibration(sid, 0, MID, MID - h, MID + h, 1)
    joints[GRIPPER] = JointCalibration(GRIPPER_ID, 0, MID, MID, MID + round(100 / 360 * T.STEPS_PER_TURN), 1)
    return ArmCalibration(model, device, name, joints)


def load_calibration(name: str, model: str, device: str, *, emulated: bool = False) -> ArmCalibration:
    path = calibration_path(name, model, device)
    if path.is_file():
        return ArmCalibration.from_json(path.read_text(encoding="utf-8"), str(path))
    if emulated:
        return default_calibration(model, device, name)
    raise CalibrationError(f"no calibration '{name}' for the {model} {device} ({path} does not exist); run "
                           f"`rio so100 calibrate --port PORT --model {model} --device {device} --name {name}`")


def apply_calibration(bus, joints: dict[str, JointCalibration]) -> bool:
    """Make the servos' homing offsets and position limits match the calibration (EEPROM writes only
    where they differ, torque off while writing). Returns True if anything was written."""
    wrong = []
    for jc in joints.values():
        have = (bus.read(jc.id, T.HOMING_OFFSET), bus.read(jc.id, T.MIN_POSITION_LIMIT),
                bus.read(jc.id, T.MAX_POSITION_LIMIT))
        if have != (jc.homing_offset, jc.range_min, jc.range_max):
            wrong.append(jc)
    for jc in wrong:
        bus.write(jc.id, T.TORQUE_ENABLE, 0)
        bus.write(jc.id, T.LOCK, 0)
        bus.write(jc.id, T.HOMING_OFFSET, jc.homing_offset)
        bus.write(jc.id, T.MIN_POSITION_LIMIT, jc.range_min)
        bus.write(jc.id, T.MAX_POSITION_LIMIT, jc.range_max)
        bus.write(jc.id, T.LOCK, 1)
    return bool(wrong)
