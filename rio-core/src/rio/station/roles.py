"""Station roles: the names under `[components]` and which kind of component each one takes.

Roles are fixed names (not free labels) because embodiments are inferred from them: `arm` alone is
a single arm, `arm` + `arm2` a bimanual pair, `humanoid` a humanoid, `base` + `arm` a mobile
manipulator. Cameras and extra sensors are open-ended: any `<name>_camera` / `<name>_sensor`.
"""

from __future__ import annotations

import re

FIXED = {
    "arm": "arm", "arm2": "arm",
    "gripper": "gripper", "gripper2": "gripper",
    "hand": "hand", "hand2": "hand",
    "humanoid": "humanoid",
    "base": "base",
    "teleop": "teleop", "teleop2": "teleop",
    "policy": "policy",
}
SUFFIXES = {"_camera": "camera", "_sensor": "sensor"}

ALL_ROLES_TEXT = ", ".join([*FIXED, "<name>_camera", "<name>_sensor"]) + " (<name>: letters, digits, _)"
#: What a `<name>_camera` / `<name>_sensor` name may be: it names files and columns in datasets, so no path
#: separators, dots or spaces ("../../escaped_camera" made the recorder write outside the dataset).
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


def kind_of(role: str) -> str | None:
    """The component kind a role takes, or None for an unknown role."""
    if role in FIXED:
        return FIXED[role]
    for suffix, kind in SUFFIXES.items():
        if role.endswith(suffix) and _NAME.fullmatch(role[: -len(suffix)]):
            return kind
    return None


def hook_of(kind: str) -> str:
    """The hook that registers components of `kind`."""
    return "rio_policies" if kind == "policy" else "rio_drivers"


def camera_name(role: str) -> str:
    """'front_camera' -> 'front': the key of the camera in `Observation.cameras`."""
    return role[: -len("_camera")]


def sensor_name(role: str) -> str:
    """'ft_sensor' -> 'ft': the key of the sensor in a step's `meta["sensors"]`."""
    return role[: -len("_sensor")]
