"""The teleop node shared by rio-teleop's twist devices (SpaceMouse, gamepads), in the shape of the
core's `teleop.keyboard`: its driver reads the device in the node's loop and publishes the standard
teleop sample (`twist`, `gripper`, `buttons`; `rio.interfaces.teleop`).

A device plugs in as a `DeviceInput` (opened by the node's `open_input()`): `poll()` reads all input
waiting and reports each change of the buttons held (so a press shorter than a cycle is not missed),
`values()` gives the named axes normalised (`rio_teleop.axes`). The node maps them with one
`TwistMap` (axes) and one `ButtonActions` (buttons).

Buttons: `keys` binds actions to the device's button names (over the device's defaults; "" unbinds):

    gripper  toggles the gripper on each press (open at start)
    mode     buttons[BUTTON_MODE] while held: `rio teleop` cycles the teleop mode
    done     stop: buttons[BUTTON_DONE], the run ends (the keyboard's q)
    keep     the run ends (BUTTON_DONE) with buttons[BUTTON_KEEP]: keep the episode
    discard  the run ends (BUTTON_DONE) with buttons[BUTTON_DISCARD]: discard the episode

done, keep and discard latch until the loop calls the node's `reset()` (as the keyboard's q does).
`rio teleop --record` keeps or discards the episode on keep / discard without asking, and asks (in a
terminal) when the run ended on done.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import Any, Protocol

import numpy as np
from pydantic import Field, field_validator

from rio.control.teleop import BUTTON_DISCARD, BUTTON_DONE, BUTTON_KEEP, BUTTON_MODE
from rio.errors import RioError
from rio.interfaces import TeleopNode
from rio.interfaces.teleop import TeleopConfig
from rio.runtime.node import remote

from .axes import TwistMap, parse_source

ACTIONS = ("gripper", "mode", "done", "keep", "discard")


class ButtonActions:
    """Held device buttons -> gripper and the published buttons (see the module docstring)."""

    def __init__(self, keys: Mapping[str, str], n_buttons: int):
        self.keys = {a: b for a, b in keys.items() if b}
        self.n = int(n_buttons)
        self.gripper = 1.0
        self.mode = False
        self.latched: set[str] = set()
        self._held: frozenset[str] = frozenset()

    def update(self, held: Iterable[str]) -> None:
        held = frozenset(held)
        new = held - self._held
        self._held = held
        if self.keys.get("gripper") in new:
            self.gripper = 0.0 if self.gripper > 0.5 else 1.0
        self.latched |= {a for a in ("done", "keep", "discard") if self.keys.get(a) in new}
        self.mode = self.keys.get("mode") in held

    def buttons(self) -> np.ndarray:
        out = np.zeros(self.n, bool)
        flags = {BUTTON_MODE: self.mode, BUTTON_DONE: bool(self.latched), BUTTON_KEEP: "keep" in self.latched,
                 BUTTON_DISCARD: "discard" in self.latched}
        for i, on in flags.items():
            out[i:i + 1] = on  # where the configured buttons include it
        return out

    def reset(self) -> None:
        self.latched.clear()

    def describe(self) -> str:
        return ", ".join(f"{b} {a}" for a, b in self.keys.items()) or "no buttons bound"


class DeviceInput(Protocol):
    label: str                      # "SpaceMouse Compact", "Xbox Wireless Controller at /dev/input/event7"
    axis_names: tuple[str, ...]     # what values() may hold (TwistMap sources)
    button_names: tuple[str, ...]   # what poll() may report held
    default_axes: list[str]
    default_keys: dict[str, str]
    flats: dict[str, float]         # per axis: the device's own noise band (fraction), on top of `deadband`

    def poll(self, on_buttons: Callable[[frozenset[str]], None]) -> None: ...
    def values(self) -> dict[str, float]: ...
    def close(self) -> None: ...


class TwistDeviceNode(TeleopNode):
    """Base of the SpaceMouse and gamepad nodes: subclasses implement `open_input()` (and `HELP`)."""

    class Config(TeleopConfig):
        """The fields every twist device takes (subclasses add the device's own)."""

        buttons: int = Field(4, ge=0, le=64, description="buttons published: mode, done, keep, discard")
        speed: float = Field(0.1, gt=0, description="tool speed at full deflection (m/s)")
        rot_speed: float = Field(0.8, gt=0, description="tool rotation speed at full deflection (rad/s)")
        deadband: float = Field(0.1, ge=0, lt=1, description="fraction of each axis's travel that reads 0")
        axes: list[str] | None = Field(None, min_length=6, max_length=6,
                                       description="device axis driving twist x, y, z, roll, pitch, yaw (robot base "
                                                   "frame); '-' flips one, '' leaves it at 0; default: the device's")
        scale: list[float] = Field([1.0] * 6, min_length=6, max_length=6,
                                   description="factor per twist component on top of speed / rot_speed")
        keys: dict[str, str] = Field(default_factory=dict,
                                     description="action (gripper, mode, done, keep, discard) -> device button; "
                                                 "over the device's defaults, '' unbinds")
        rate_hz: float = Field(100.0, gt=0)

        @field_validator("axes")
        @classmethod
        def _axes(cls, v: list[str] | None) -> list[str] | None:
            for a in v or []:
                parse_source(a)
            return v

        @field_validator("keys")
        @classmethod
        def _keys(cls, v: dict[str, str]) -> dict[str, str]:
            bad = sorted(set(v) - set(ACTIONS))
            if bad:
                raise ValueError(f"unknown action(s) {bad}; actions: {', '.join(ACTIONS)}")
            return v

    device_name = "teleop.device"
    HELP = ""

    def setup(self) -> None:
        super().setup()
        self.input: DeviceInput | None = None
        self.actions = ButtonActions({}, self.config.buttons)

    def open_input(self) -> DeviceInput:
        raise NotImplementedError

    def open(self) -> None:
        dev = self.open_input()
        c = self.config
        try:
            self.twist_map = TwistMap(c.axes or dev.default_axes, speed=c.speed, rot_speed=c.rot_speed,
                                      deadband=c.deadband, scale=c.scale, known=dev.axis_names, device=dev.label)
            keys = {**dev.default_keys, **c.keys}
            bad = sorted(b for b in keys.values() if b and b not in dev.button_names)
            if bad:
                raise ValueError(f"{dev.label} has no button {', '.join(map(repr, bad))}; its buttons: "
                                 f"{', '.join(dev.button_names) or 'none'}")
        except ValueError as e:
            dev.close()
            raise RioError(f"{self.device_name}: {e}") from None
        self.input, self.actions = dev, ButtonActions(keys, c.buttons)

    def close(self) -> None:
        if self.input is not None:
            self.input.close()
            self.input = None

    def read_state(self) -> dict[str, Any]:
        assert self.input is not None  # opened in open()
        self.input.poll(self.actions.update)
        return {"twist": self.twist_map(self.input.values(), self.input.flats), "gripper": self.actions.gripper,
                "buttons": self.actions.buttons()}

    @remote
    def reset(self) -> float:
        self.actions.reset()
        return 0.0

    @remote
    def help(self) -> str:
        where = self.input.label if self.input is not None else self.device_name
        return f"{where}: {self.HELP}; buttons: {self.actions.describe()}"


TwistDeviceConfig = TwistDeviceNode.Config
