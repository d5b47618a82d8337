"""Which of this repository's plugins provides a name, so "unknown station 'sim-so100'" can say what to install.

A name that is not registered is most often one whose plugin is simply not installed (rio-core alone,
then `rio teleop sim-so100`). The registry cannot know about a plugin that is not there, so this small
table records, by name pattern, what the plugins shipped with RIO provide. Third-party plugins are not
listed: for them the usual "did you mean" suggestion is all `rio` can offer.

The same table is the list of this repository's distribution names, planned ones included (they
provide nothing yet, so they never appear in a hint): `rio new plugin` refuses a name that would
clash with one of them (`repository_plugin`).
"""

from __future__ import annotations

import re
from fnmatch import fnmatchcase

from rio.plugins.specs import DRIVER_KINDS

#: distribution -> {kind group: shell-style name patterns}. Kind groups: "driver" (any driver kind),
#: "policy", "dataset_format", "station". Keep in step with each plugin's plugin.py. A planned plugin
#: is listed with nothing yet: its name is taken, and no hint sends anyone to install it.
KNOWN: dict[str, dict[str, tuple[str, ...]]] = {
    "rio-core": {},  # the core's own names are always installed
    "rio-sim": {"driver": ("sim.*",), "station": ("sim-*",)},
    "rio-so100": {"driver": ("so100.*", "so101.*"), "station": ("so100", "so100-*", "so101", "so101-*")},
    "rio-policies": {"policy": ("openpi.*", "gr00t.*", "onnx.*", "lerobot.*", "replay.*")},
    "rio-datasets": {"dataset_format": ("lerobot", "zarr", "hdf5")},
    "rio-ufactory": {"driver": ("ufactory.*",), "station": ("xarm*", "lite6*")},
    "rio-robotiq": {"driver": ("robotiq.*", "dh.*"), "station": ("robotiq-*",)},
    "rio-ati": {"driver": ("ati.*",), "station": ("ati-*",)},
    "rio-ur": {"driver": ("ur.*",), "station": ("ur3e*", "ur5e*", "ur7e*", "ur10e*", "ur12e*", "ur16e*")},
    "rio-franka": {"driver": ("franka.*",), "station": ("fr3*", "panda*")},
    "rio-kinova": {"driver": ("kinova.*",), "station": ("gen3*",)},
    "rio-realsense": {"driver": ("realsense.*",), "station": ("realsense-*",)},
    "rio-cameras": {"driver": ("cameras.*",), "station": ("cameras-*",)},
    "rio-ros2": {},  # `rio ros2 bridge`: a command, no names
    "lerobot-robot-rio": {},  # installed next to LeRobot: provides LeRobot's `--robot.type=rio`
    "rio-teleop": {"driver": ("gello.*", "teleop.spacemouse", "teleop.gamepad", "teleop.xbox", "teleop.playstation",
                              "teleop.webxr*", "teleop.avp"), "station": ("gello-*",)},
    # planned
    "rio-unitree": {}, "rio-booster": {},
}


def _group(kind: str) -> str:
    return "driver" if kind in DRIVER_KINDS else kind


def normalize(dist: str) -> str:
    """A distribution name in its normalized form (PEP 503): lowercase, runs of '-', '_', '.' as one '-'."""
    return re.sub(r"[-_.]+", "-", dist).lower()


def repository_plugin(dist: str) -> str | None:
    """`dist` as this repository names it when it is one of its distributions (shipped or planned),
    whatever its spelling (`RIO_Sim`, `rio.sim`); None otherwise."""
    want = normalize(dist)
    return next((d for d in KNOWN if d == want), None)


def provider(kind: str, name: str) -> str | None:
    """The known distribution that provides `name` of `kind` (a spec kind or a kind group), or None."""
    group = _group(kind)
    for dist, provides in KNOWN.items():
        if any(fnmatchcase(name, pattern) for pattern in provides.get(group, ())):
            return dist
    return None


def install_hint(kind: str, name: str, installed: set[str]) -> str | None:
    """" (provided by rio-sim, which is not installed: pip install rio-sim)" when a known plugin that is
    not in `installed` (distribution names) provides `name`; None otherwise."""
    dist = provider(kind, name)
    if dist is None or dist in {normalize(d) for d in installed}:
        return None
    return f" (provided by {dist}, which is not installed: pip install {dist})"


def missing_plugin_hint(kind: str, name: str, loaded: set[str]) -> str | None:
    """Like `install_hint` for the plugins `loaded` in this process, but honest when the distribution is
    installed and was not loaded (left out by RIO_LOAD_PLUGINS, or its import failed): installing it
    again would not help, so point at `rio doctor` instead."""
    hint = install_hint(kind, name, loaded)
    dist = provider(kind, name)
    if hint is None or dist is None:
        return None
    from importlib.metadata import PackageNotFoundError, distribution

    try:
        distribution(dist)
    except PackageNotFoundError:
        return hint
    return (f" (provided by {dist}, which is installed but not loaded: see `rio doctor` for its problems, "
            "or RIO_LOAD_PLUGINS)")
