"""What cameras are connected, across every camera plugin: `rio cameras list`.

A camera plugin declares listers (`rio_camera_listers` hook: 'module:function' paths); each returns the
devices its SDK sees as `CameraDevice`s, naming the station driver that opens one and the station field
that selects it, so a user can copy the line into a station file. Listers run only here: listing drivers
or loading a station never touches a camera SDK. A lister that fails (SDK missing, USB permission) is
reported as one line naming its plugin; the others still list.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any


@dataclass(frozen=True)
class CameraDevice:
    #: The station driver that opens it ("realsense.d400", "cameras.uvc").
    driver: str
    #: The value that selects this device, and the station field that takes it.
    id: str
    model: str
    select_field: str = "serial"
    firmware: str = ""
    #: Modes it offers, as "640x480@30 rgb8" / "848x480@90 z16" (as many as the SDK reports).
    modes: tuple[str, ...] = field(default_factory=tuple)
    note: str = ""

    def as_dict(self) -> dict[str, Any]:
        return {**asdict(self), "modes": list(self.modes)}

    def station_line(self) -> str:
        """The station-file lines that pick this device."""
        return f'driver = "{self.driver}"\n{self.select_field} = "{self.id}"'


def list_cameras(registry: Any = None) -> tuple[list[CameraDevice], list[str]]:
    """Every connected camera the installed plugins can see, and one line per lister that failed."""
    from rio.plugins import get_registry
    from rio.plugins.specs import import_path

    reg = registry or get_registry()
    devices: list[CameraDevice] = []
    problems: list[str] = []
    for plugin, path in reg.camera_listers():
        try:
            found = import_path(path)()
        except Exception as e:  # an SDK that is missing or cannot reach USB: say so, keep listing
            problems.append(f"{plugin} ({path}): {type(e).__name__}: {e}")
            continue
        for dev in found or []:
            if isinstance(dev, CameraDevice):
                devices.append(dev)
            else:
                problems.append(f"{plugin} ({path}): returned {type(dev).__name__}, not a CameraDevice")
    return devices, problems
