"""`teleop.spacemouse`: end-effector teleop from a 3Dconnexion SpaceMouse (Compact, Wireless, Pro,
Enterprise and the older SpaceNavigator/SpacePilot family; every model in pyspacemouse's device table).

The device is read over HID (hidapi through easyhid) with pyspacemouse's own device table and report
parsing, in its ROS axis convention: push the cap away from you = +x, left = +y, up = +z, and
rotations about those axes (right-handed). With the robot in front of you, facing away, that is its
base frame; `axes` remaps it otherwise (`rio_teleop.axes`). Each node cycle drains every report
waiting, so the Compact's separate translation and rotation reports both land and no press is missed.

Default buttons: two-button models (Compact, Wireless, SpaceNavigator): LEFT toggles the gripper,
RIGHT is done. Models with numbered buttons (Pro, Enterprise, SpacePilot): 1 gripper, 2 mode, 3 keep,
4 discard, ESC done. `keys` rebinds them by pyspacemouse's button names (`rio_teleop.twist_device`).
"""

from __future__ import annotations

import contextlib
import io
from collections.abc import Callable
from typing import Any

from pydantic import Field

from rio.errors import RioError

from ..axes import TWIST_AXES
from ..twist_device import TwistDeviceConfig, TwistDeviceNode

NAME = "teleop.spacemouse"
MAX_REPORTS = 64  # reports drained per cycle at most (a SpaceMouse sends about one per 8 ms per channel)
TWO_BUTTONS = {"gripper": "LEFT", "done": "RIGHT"}
NUMBERED = {"gripper": "BTN_1", "mode": "BTN_2", "keep": "BTN_3", "discard": "BTN_4", "done": "ESC"}
UDEV_RULE = ('KERNEL=="hidraw*", ATTRS{idVendor}=="256f", MODE="0666"\n'
             'KERNEL=="hidraw*", ATTRS{idVendor}=="046d", ATTRS{idProduct}=="c6[0-9a-f][0-9a-f]", MODE="0666"')
UDEV_HINT = ("on Linux, hidraw devices are root-only until a udev rule opens them: put\n" + UDEV_RULE
             + "\ninto /etc/udev/rules.d/99-spacemouse.rules, run `sudo udevadm control --reload-rules && "
               "sudo udevadm trigger`, then replug (docs: plugins/rio-teleop/docs/spacemouse.md)")
HIDAPI_HINT = ("the hidapi library is not installed (easyhid loads it): `sudo apt install libhidapi-hidraw0` "
               "(Debian/Ubuntu), `brew install hidapi` (macOS)")


def default_keys(button_names: tuple[str, ...]) -> dict[str, str]:
    if "LEFT" in button_names and "RIGHT" in button_names:
        return dict(TWO_BUTTONS)
    return {a: b for a, b in NUMBERED.items() if b in button_names}


class SpaceMouseInput:
    """A pyspacemouse `SpaceMouseDevice` as a `DeviceInput` (rio_teleop.twist_device)."""

    axis_names: tuple[str, ...] = TWIST_AXES
    default_axes = list(TWIST_AXES)
    flats: dict[str, float] = {}

    def __init__(self, mouse: Any):
        from easyhid import HIDException

        self.mouse, self._hid_error = mouse, HIDException
        self.label = f"SpaceMouse {mouse.name}"
        self.button_names = tuple(mouse.info.button_names)
        self.default_keys = default_keys(self.button_names)
        self.state: Any = None  # pyspacemouse's state object, updated in place by each report it parses

    def poll(self, on_buttons: Callable[[frozenset[str]], None]) -> None:
        for _ in range(MAX_REPORTS):
            t_before = self.state.t if self.state is not None else -1.0  # -1: pyspacemouse's "never read"
            try:
                self.state = self.mouse.read()  # one HID report through pyspacemouse's parser, if one waits
            except self._hid_error as e:
                raise RioError(f"{NAME}: {self.label} stopped answering ({e}): unplugged, or its receiver "
                               "lost it") from None
            if self.state.t == t_before:  # nothing was waiting (pyspacemouse stamps each report it parses)
                return
            on_buttons(frozenset(n for n, b in zip(self.button_names, self.state.buttons, strict=False) if b))

    def values(self) -> dict[str, float]:
        s = self.state
        return {a: float(getattr(s, a)) for a in TWIST_AXES} if s is not None else {}

    def close(self) -> None:
        self.mouse.close()


def open_spacemouse(device: str | None = None, index: int = 0) -> SpaceMouseInput:
    """The first (or the named, `index`-th) SpaceMouse, opened; RioError saying what to do if not."""
    try:
        import pyspacemouse
        from pyspacemouse import AxisConvention
    except ImportError as e:
        raise RioError(f"{NAME} needs pyspacemouse ({e}): pip install pyspacemouse") from None
    known = list(pyspacemouse.get_device_specs())
    if device is not None and device not in known:
        raise RioError(f"{NAME}: unknown device {device!r}; pyspacemouse knows {', '.join(known)}")
    what = device or "3Dconnexion SpaceMouse"
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # pyspacemouse prints "<name> found"
            mouse = pyspacemouse.open(device=device, device_index=index, nonblocking=True,
                                      axis_convention=AxisConvention.ROS)
    except AttributeError as e:  # easyhid found no hidapi library: its functions are missing
        raise RioError(f"{NAME}: cannot look for a {what}: {HIDAPI_HINT} ({e})") from None
    except RuntimeError as e:
        text = f"{e} {e.__cause__ or ''}"
        if "HID API" in text:
            raise RioError(f"{NAME}: cannot look for a {what}: {HIDAPI_HINT}") from None
        if "Failed to open" in text:
            raise RioError(f"{NAME}: found {what} but may not open it; {UDEV_HINT}") from None
        raise RioError(f"{NAME}: no {what} found (pyspacemouse: {e}). Plug it in (a wireless one: its "
                       f"receiver, and switch it on); if it is plugged, {UDEV_HINT}") from None
    return SpaceMouseInput(mouse)


class SpaceMouseTeleop(TwistDeviceNode):
    class Config(TwistDeviceConfig):
        device: str | None = Field(None, description="pyspacemouse model name (SpaceMouseCompact, "
                                                     "SpaceMouseWireless, ...); default: the first one found")
        index: int = Field(0, ge=0, description="which one, when several of that model are plugged in")

    device_name = NAME
    HELP = "push, pull and tilt the cap to move the tool"

    def open_input(self) -> SpaceMouseInput:
        return open_spacemouse(self.config.device, self.config.index)


SpaceMouseTeleopConfig = SpaceMouseTeleop.Config
