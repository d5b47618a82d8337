"""teleop.gamepad on recorded evdev event streams.

There is no /dev/uinput on CI to create a virtual pad, so each test plays a recorded stream of
`evdev.InputEvent(sec, usec, type, code, value)` (with SYN_REPORT frames, as the kernel sends them)
from a stand-in for `evdev.InputDevice`: only the device side is faked (its `read()` source, and the
absinfo/capabilities/active-keys answers a real pad gives: an Xbox One pad on xpad, a DualSense on
hid-playstation, a DirectInput pad). The event parsing, absinfo normalisation, mapping, discovery
and the node are the real code.
"""

from __future__ import annotations

import time
import types
from contextlib import contextmanager
from unittest import mock

import evdev
import numpy as np
import pytest
from evdev import AbsInfo, InputEvent
from evdev import ecodes as e
from rio_teleop.gamepad.driver import GamepadTeleop

from rio.conformance.drivers import TeleopConformance
from rio.control.teleop import BUTTON_DISCARD, BUTTON_DONE, BUTTON_KEEP, BUTTON_MODE
from rio.errors import RioError
from rio.testing import fake_eef_station

STICK16 = AbsInfo(0, -32768, 32767, 16, 128, 0)
HAT = AbsInfo(0, -1, 1, 0, 0, 0)
XBOX_ONE = {  # xpad, "Microsoft X-Box One S pad" (045e:02ea)
    "name": "Microsoft X-Box One S pad", "vendor": 0x045E,
    "abs": {e.ABS_X: STICK16, e.ABS_Y: STICK16, e.ABS_RX: STICK16, e.ABS_RY: STICK16,
            e.ABS_Z: AbsInfo(0, 0, 1023, 0, 0, 0), e.ABS_RZ: AbsInfo(0, 0, 1023, 0, 0, 0),
            e.ABS_HAT0X: HAT, e.ABS_HAT0Y: HAT},
    "keys": [e.BTN_A, e.BTN_B, e.BTN_X, e.BTN_Y, e.BTN_TL, e.BTN_TR, e.BTN_SELECT, e.BTN_START, e.BTN_MODE,
             e.BTN_THUMBL, e.BTN_THUMBR]}
STICK8 = AbsInfo(128, 0, 255, 0, 0, 0)
DUALSENSE = {  # hid-playstation, "Sony Interactive Entertainment DualSense Wireless Controller" (054c:0ce6)
    "name": "Sony Interactive Entertainment DualSense Wireless Controller", "vendor": 0x054C,
    "abs": {e.ABS_X: STICK8, e.ABS_Y: STICK8, e.ABS_RX: STICK8, e.ABS_RY: STICK8,
            e.ABS_Z: AbsInfo(0, 0, 255, 0, 0, 0), e.ABS_RZ: AbsInfo(0, 0, 255, 0, 0, 0),
            e.ABS_HAT0X: HAT, e.ABS_HAT0Y: HAT},
    "keys": [e.BTN_SOUTH, e.BTN_EAST, e.BTN_NORTH, e.BTN_WEST, e.BTN_TL, e.BTN_TR, e.BTN_TL2, e.BTN_TR2,
             e.BTN_SELECT, e.BTN_START, e.BTN_MODE, e.BTN_THUMBL, e.BTN_THUMBR]}
DUALSENSE_MOTION = {"name": "Sony Interactive Entertainment DualSense Wireless Controller Motion Sensors",
                    "vendor": 0x054C, "keys": [],
                    "abs": {c: AbsInfo(0, -32768, 32767, 3, 0, 8192) for c in (e.ABS_X, e.ABS_Y, e.ABS_Z)}}
DUALSENSE_TOUCHPAD = {"name": "Sony Interactive Entertainment DualSense Wireless Controller Touchpad",
                      "vendor": 0x054C, "keys": [e.BTN_LEFT, e.BTN_TOUCH, e.BTN_TOOL_FINGER],
                      "abs": {e.ABS_X: AbsInfo(0, 0, 1919, 0, 0, 0), e.ABS_Y: AbsInfo(0, 0, 1079, 0, 0, 0)}}
GENERIC = {  # a DirectInput pad (Logitech F310 in D mode, 046d:c216): right stick on Z/RZ, numbered buttons
    "name": "Logitech Logitech Dual Action", "vendor": 0x046D,
    "abs": {e.ABS_X: AbsInfo(128, 0, 255, 0, 15, 0), e.ABS_Y: AbsInfo(128, 0, 255, 0, 15, 0),
            e.ABS_Z: AbsInfo(128, 0, 255, 0, 15, 0), e.ABS_RZ: AbsInfo(128, 0, 255, 0, 15, 0),
            e.ABS_HAT0X: HAT, e.ABS_HAT0Y: HAT},
    "keys": list(range(e.BTN_TRIGGER, e.BTN_BASE6 + 1))}


def frame(t: float, *changes: tuple[int, int, int]) -> list[InputEvent]:
    """One kernel report at time t: its changes, then SYN_REPORT."""
    sec, usec = int(t), int(round((t % 1) * 1e6))
    return [InputEvent(sec, usec, *c) for c in changes] + [InputEvent(sec, usec, e.EV_SYN, e.SYN_REPORT, 0)]


def ax(code, value):
    return (e.EV_ABS, code, value)


def key(code, value):
    return (e.EV_KEY, code, value)


class FakePad:
    """Stands in for evdev.InputDevice: a recorded pad's answers, and `read()` replaying events
    (`feed()` them, or a `timeline` of (seconds after opening, events) played as time passes)."""

    def __init__(self, rec, path="/dev/input/event7", timeline=()):
        self.name, self.path = rec["name"], path
        self.info = types.SimpleNamespace(bustype=3, vendor=rec["vendor"], product=0, version=0x0111)
        self._abs = {c: a for c, a in rec["abs"].items()}
        self._keys = list(rec["keys"])
        self.queue: list[InputEvent] = []
        self.timeline, self.t0, self.closed, self.held = list(timeline), time.monotonic(), False, set()
        self.unplugged = False

    def capabilities(self, verbose=False, absinfo=True):
        caps = {e.EV_SYN: [0], e.EV_ABS: [(c, a) if absinfo else c for c, a in self._abs.items()]}
        if self._keys:
            caps[e.EV_KEY] = list(self._keys)
        return caps

    def absinfo(self, code):
        return self._abs[code]

    def active_keys(self, verbose=False):
        return sorted(self.held)

    def feed(self, *frames):
        for f in frames:
            self.queue += f

    def read(self):
        if self.unplugged:
            raise OSError(19, "No such device")
        while self.timeline and self.timeline[0][0] <= time.monotonic() - self.t0:
            self.queue += self.timeline.pop(0)[1]
        if not self.queue:
            raise BlockingIOError(11, "Resource temporarily unavailable")
        out, self.queue = self.queue, []
        for ev in out:  # what the kernel's own state would then say (for SYN_DROPPED resyncs)
            if ev.type == e.EV_ABS:
                self._abs[ev.code] = self._abs[ev.code]._replace(value=ev.value)
            elif ev.type == e.EV_KEY:
                (self.held.add if ev.value else self.held.discard)(ev.code)
        return iter(out)

    def close(self):
        self.closed = True


@pytest.fixture
def plugged(monkeypatch):
    """`plugged(FakePad(...), ...)`: the pads evdev lists and opens."""
    def plug(*pads):
        by_path = {p.path: p for p in pads}

        def open_device(path):
            if path not in by_path:
                raise FileNotFoundError(2, "No such file or directory", path)
            return by_path[path]

        monkeypatch.setattr(evdev, "list_devices", lambda *a, **k: list(by_path))
        monkeypatch.setattr(evdev, "InputDevice", open_device)
        return pads[0] if pads else None
    return plug


def opened(**config) -> GamepadTeleop:
    node = GamepadTeleop(backend="evdev", **config)
    node.open()
    return node


def test_xbox_sticks_triggers_bumpers_to_the_base_frame(plugged):
    pad = plugged(FakePad(XBOX_ONE))
    node = opened(speed=0.1, rot_speed=0.8, deadband=0.1)
    assert node.input.label.startswith("Xbox controller 'Microsoft X-Box One S pad'")
    assert np.allclose(node.read_state()["twist"], 0)
    pad.feed(frame(0.01, ax(e.ABS_Y, -32768)))  # left stick fully up: forward
    assert np.allclose(node.read_state()["twist"], [0.1, 0, 0, 0, 0, 0])
    pad.feed(frame(0.02, ax(e.ABS_Y, 0), ax(e.ABS_X, -16384)))  # half left: +y, past the deadband
    assert np.allclose(node.read_state()["twist"], [0, 0.1 * (0.5 - 0.1) / 0.9, 0, 0, 0, 0], atol=1e-4)
    pad.feed(frame(0.03, ax(e.ABS_X, 0), ax(e.ABS_RZ, 1023)))  # RT fully: up
    assert np.allclose(node.read_state()["twist"], [0, 0, 0.1, 0, 0, 0])
    pad.feed(frame(0.04, ax(e.ABS_Z, 1023)))  # LT too: they cancel
    assert np.allclose(node.read_state()["twist"], 0)
    pad.feed(frame(0.05, ax(e.ABS_Z, 0), ax(e.ABS_RZ, 0), ax(e.ABS_RX, 32767), ax(e.ABS_RY, -32768)))
    assert np.allclose(node.read_state()["twist"], [0, 0, 0, 0.8, 0.8, 0])  # right stick: roll right, pitch down
    pad.feed(frame(0.06, ax(e.ABS_RX, 0), ax(e.ABS_RY, 0), key(e.BTN_TL, 1)))
    assert np.allclose(node.read_state()["twist"], [0, 0, 0, 0, 0, 0.8])  # LB: yaw left
    pad.feed(frame(0.07, key(e.BTN_TL, 0), key(e.BTN_TR, 1)))
    assert np.allclose(node.read_state()["twist"], [0, 0, 0, 0, 0, -0.8])
    node.close()
    assert pad.closed


def test_dualsense_0_255_sticks_read_like_xbox_and_drift_stays_in_the_deadband(plugged):
    pad = plugged(FakePad(DUALSENSE))
    node = opened(deadband=0.1)
    assert node.input.label.startswith("PlayStation controller")
    pad.feed(frame(0.01, ax(e.ABS_X, 139), ax(e.ABS_Y, 119), ax(e.ABS_RX, 120)))  # a worn stick at rest
    assert np.allclose(node.read_state()["twist"], 0)
    pad.feed(frame(0.02, ax(e.ABS_Y, 0), ax(e.ABS_X, 128), ax(e.ABS_RX, 128), ax(e.ABS_Z, 255)))  # up, L2 full
    assert np.allclose(node.read_state()["twist"], [0.1, 0, -0.1, 0, 0, 0])


def test_axis_flat_from_absinfo_widens_the_deadband(plugged):
    pad = plugged(FakePad(GENERIC))  # flat 15 of 127.5: 12 % of the travel
    node = opened(deadband=0.02)
    pad.feed(frame(0.01, ax(e.ABS_Y, 128 - 14)))  # 11 % up: inside the pad's own flat band
    assert np.allclose(node.read_state()["twist"], 0)
    pad.feed(frame(0.02, ax(e.ABS_Y, 0)))
    assert node.read_state()["twist"][0] == pytest.approx(0.1)


def test_generic_pad_digital_triggers_right_stick_on_z_rz_and_numbered_buttons(plugged):
    pad = plugged(FakePad(GENERIC))
    node = opened()
    assert node.input.label.startswith("gamepad 'Logitech")
    pad.feed(frame(0.01, key(e.BTN_BASE2, 1), ax(e.ABS_Z, 255)))  # "8" (R2) held: up; right stick right: roll
    assert np.allclose(node.read_state()["twist"], [0, 0, 0.1, 0.8, 0, 0], atol=0.01)
    pad.feed(frame(0.015, key(e.BTN_BASE2, 0), ax(e.ABS_Z, 128)))
    pad.feed(frame(0.02, key(e.BTN_THUMB, 1)), frame(0.03, key(e.BTN_THUMB, 0)))  # "2" (south): gripper
    assert node.read_state()["gripper"] == 0.0
    pad.feed(frame(0.04, key(e.BTN_BASE4, 1)))  # start: keep
    b = node.read_state()["buttons"]
    assert b[BUTTON_DONE] and b[BUTTON_KEEP]


def test_xbox_buttons_gripper_mode_and_episode_keys(plugged):
    pad = plugged(FakePad(XBOX_ONE))
    node = opened()
    pad.feed(frame(0.01, key(e.BTN_A, 1)), frame(0.05, key(e.BTN_A, 0)))  # a tap between two cycles
    s = node.read_state()
    assert s["gripper"] == 0.0 and not s["buttons"].any()
    pad.feed(frame(0.10, key(e.BTN_Y, 1)))  # physical Y (xpad: BTN_Y, the kernel's "west" code) = north: mode
    assert node.read_state()["buttons"][BUTTON_MODE]
    pad.feed(frame(0.12, key(e.BTN_Y, 2)))  # autorepeat changes nothing
    assert node.read_state()["buttons"][BUTTON_MODE]
    pad.feed(frame(0.15, key(e.BTN_Y, 0)))
    assert not node.read_state()["buttons"].any()
    pad.feed(frame(0.2, key(e.BTN_X, 1)), frame(0.25, key(e.BTN_X, 0)))  # X (west) is unbound
    assert not node.read_state()["buttons"].any()
    pad.feed(frame(0.3, key(e.BTN_START, 1)), frame(0.35, key(e.BTN_START, 0)))
    b = node.read_state()["buttons"]
    assert b[BUTTON_DONE] and b[BUTTON_KEEP] and not b[BUTTON_DISCARD]
    node.reset()
    pad.feed(frame(0.4, key(e.BTN_SELECT, 1)))
    b = node.read_state()["buttons"]
    assert b[BUTTON_DONE] and b[BUTTON_DISCARD] and not b[BUTTON_KEEP]
    node.reset()
    pad.feed(frame(0.5, key(e.BTN_SELECT, 0), key(e.BTN_MODE, 1)))  # the Xbox button: stop
    assert node.read_state()["buttons"].tolist() == [False, True, False, False]
    assert "south gripper" in node.help()


def test_keys_by_the_family_labels_and_the_playstation_layout(plugged):
    pad = plugged(FakePad(DUALSENSE))
    node = opened(keys={"gripper": "circle", "mode": "square", "done": "", "discard": "options"})
    pad.feed(frame(0.01, key(e.BTN_EAST, 1), key(e.BTN_WEST, 1)))
    s = node.read_state()
    assert s["gripper"] == 0.0 and s["buttons"][BUTTON_MODE]
    pad.feed(frame(0.02, key(e.BTN_START, 1)))
    assert node.read_state()["buttons"][BUTTON_DISCARD]
    with pytest.raises(RioError, match=r"has no button 'a'; its buttons: .*cross"):
        opened(keys={"gripper": "a"})  # an Xbox label on a PlayStation pad


def test_codes_move_a_control_and_mapping_flips_axes(plugged):
    bt = {**XBOX_ONE, "name": "Xbox Wireless Controller", "abs": {**XBOX_ONE["abs"]}}
    bt["abs"][e.ABS_BRAKE] = bt["abs"].pop(e.ABS_Z)  # over Bluetooth with hid-generic: brake/gas triggers
    bt["abs"][e.ABS_GAS] = bt["abs"].pop(e.ABS_RZ)
    pad = plugged(FakePad(bt))
    node = opened(family="xbox", codes={"lt": "ABS_BRAKE", "rt": "ABS_GAS"},
                  axes=["left_y", "left_x", "-triggers", "", "", ""], scale=[1, 2, 1, 1, 1, 1], deadband=0)
    pad.feed(frame(0.01, ax(e.ABS_GAS, 1023), ax(e.ABS_Y, 32767), ax(e.ABS_X, 32767)))
    assert np.allclose(node.read_state()["twist"], [0.1, 0.2, -0.1, 0, 0, 0], atol=1e-4)
    with pytest.raises(RioError, match="not an input event code"):
        opened(codes={"lt": "ABS_BREAK"})


def test_syn_dropped_rereads_the_whole_state(plugged):
    pad = plugged(FakePad(XBOX_ONE))
    node = opened()
    pad.feed(frame(0.01, ax(e.ABS_Y, -32768), key(e.BTN_A, 1)))
    node.read_state()
    pad._abs[e.ABS_Y] = pad._abs[e.ABS_Y]._replace(value=0)  # released while the kernel's buffer overflowed
    pad.held.clear()
    pad.feed([InputEvent(0, 200000, e.EV_SYN, e.SYN_DROPPED, 0)])
    s = node.read_state()
    assert np.allclose(s["twist"], 0) and s["gripper"] == 0.0  # the stick is back; one press, one toggle


def test_finds_the_pad_among_its_touchpad_and_motion_devices(plugged):
    plugged(FakePad(DUALSENSE_TOUCHPAD, "/dev/input/event5"), FakePad(DUALSENSE_MOTION, "/dev/input/event6"),
            FakePad(DUALSENSE, "/dev/input/event7"), FakePad(XBOX_ONE, "/dev/input/event9"))
    assert opened().input.label.endswith("at /dev/input/event7")
    assert opened(device="x-box").input.label.endswith("at /dev/input/event9")
    assert opened(device="/dev/input/event9").input.label.startswith("Xbox")
    with pytest.raises(RioError, match=r"no gamepad named like 'switch' found"):
        opened(device="switch")


def test_no_gamepad_says_plug_it_in_and_the_input_group(plugged):
    plugged(FakePad(DUALSENSE_MOTION, "/dev/input/event6"))
    with pytest.raises(RioError) as err:
        opened()
    msg = str(err.value)
    assert "no gamepad (Xbox, PlayStation or generic) found" in msg and "Plug it in" in msg
    assert "usermod -aG input" in msg and "Motion Sensors" in msg
    with pytest.raises(RioError, match="does not exist"):
        opened(device="/dev/input/event42")


def test_unplugged_while_running_is_named(plugged):
    pad = plugged(FakePad(XBOX_ONE))
    node = opened()
    pad.unplugged = True
    with pytest.raises(RioError, match="Microsoft X-Box One S pad' at /dev/input/event7 stopped answering"):
        node.read_state()


def test_unknown_axis_or_action_is_a_config_error(plugged):
    plugged(FakePad(GENERIC))
    with pytest.raises(RioError, match="has no axis 'right_y2'"):
        opened(axes=["-left_y", "-left_x", "", "right_y2", "", ""])
    with pytest.raises(ValueError, match="unknown action"):
        GamepadTeleop(keys={"jump": "south"})
    with pytest.raises(ValueError, match="axis source"):
        GamepadTeleop(axes=["--left_y", "", "", "", "", ""])


def test_pygame_backend_layout():
    """The pygame (SDL game controller) backend's mapping, on a stand-in for pygame and one controller:
    only the SDL values are faked (pygame is not installed on Linux)."""
    from rio_teleop.gamepad.pygame_input import PygameInput

    names = ["LEFTX", "LEFTY", "RIGHTX", "RIGHTY", "TRIGGERLEFT", "TRIGGERRIGHT"]
    buttons = ["A", "B", "X", "Y", "BACK", "GUIDE", "START", "LEFTSTICK", "RIGHTSTICK", "LEFTSHOULDER",
               "RIGHTSHOULDER", "DPAD_UP", "DPAD_DOWN", "DPAD_LEFT", "DPAD_RIGHT"]
    pg = types.SimpleNamespace(event=types.SimpleNamespace(pump=lambda: None),
                               **{f"CONTROLLER_AXIS_{n}": i for i, n in enumerate(names)},
                               **{f"CONTROLLER_BUTTON_{n}": i for i, n in enumerate(buttons)})
    state = {"axes": [0, -32768, 0, 0, 0, 32767], "buttons": {buttons.index("A"), buttons.index("LEFTSHOULDER")}}
    pad = types.SimpleNamespace(name="Xbox Series X Controller", get_axis=lambda a: state["axes"][a],
                                get_button=lambda b: b in state["buttons"], quit=lambda: None)
    dev = PygameInput(pg, pad)
    seen = []
    dev.poll(seen.append)
    v = dev.values()
    assert v["left_y"] == -1.0 and v["triggers"] == pytest.approx(1.0) and v["bumpers"] == -1.0
    assert {"south", "a", "cross", "lb"} <= seen[0]
    state["buttons"] = {buttons.index("DPAD_UP")}
    dev.poll(seen.append)
    assert dev.values()["dpad_y"] == -1.0 and len(seen) == 2


class TestGamepadConformance(TeleopConformance):
    """The teleop driver kit on an Xbox pad replaying a recorded stream (evdev's device faked)."""

    driver = "rio_teleop.gamepad.driver:GamepadTeleop"
    config = {"backend": "evdev"}
    bad_config = {"device": "/dev/input/event42"}  # nothing there

    @contextmanager
    def emulator(self):
        timeline = [(0.0, frame(0.0, ax(e.ABS_Y, -32768), ax(e.ABS_RZ, 800))),
                    (0.05, frame(0.05, key(e.BTN_A, 1))), (0.1, frame(0.1, key(e.BTN_START, 1)))]

        def open_device(path):
            if path != "/dev/input/event7":
                raise FileNotFoundError(2, "No such file or directory", path)
            return FakePad(XBOX_ONE, timeline=timeline)

        with mock.patch.object(evdev, "list_devices", lambda *a, **k: ["/dev/input/event7"]), \
                mock.patch.object(evdev, "InputDevice", open_device):
            yield {}


STATION = fake_eef_station("gamepad-eef", 'driver = "teleop.xbox"\nspeed = 0.1', dof=3)


def test_recorded_stream_drives_rio_teleop_on_a_fake_arm(plugged, tmp_path):
    from rio.workflows.teleop import run_teleop

    timeline = [(0.3, frame(0.3, ax(e.ABS_X, -32768))),                      # left stick fully left: +y
                (0.9, frame(0.9, ax(e.ABS_X, 0))),                           # let go after 0.6 s
                (1.0, frame(1.0, key(e.BTN_A, 1))), (1.1, frame(1.1, key(e.BTN_A, 0))),  # close the gripper
                (1.4, frame(1.4, key(e.BTN_MODE, 1)))]                       # the Xbox button: done
    plugged(FakePad(XBOX_ONE, timeline=timeline))
    station = tmp_path / "pad.toml"
    station.write_text(STATION)
    poses, grips = [], []

    def on_tick(tick):
        arm = tick.info["arms"][0]
        poses.append(np.asarray(arm.client.get_state()["eef_pose"][:3], dtype=float))  # measured, not the target
        grips.append(arm.gripper_cmd)

    summary = run_teleop(str(station), duration=8.0, on_tick=on_tick, log=None)
    assert summary.reason == "the device finished", summary.format()
    moved = poses[-1] - poses[0]
    assert 0.04 < moved[1] < 0.08 and abs(moved[0]) < 1e-3 and abs(moved[2]) < 1e-3  # ~0.1 m/s for 0.6 s, +y
    assert grips[-1] == 0.0 < grips[0]


@pytest.mark.hardware
def test_real_gamepad_opens_and_reads():
    """A gamepad plugged into this machine: opens, reads for a second, publishes the layout."""
    node = GamepadTeleop()
    node.open()
    try:
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            s = node.read_state()
            assert s["twist"].shape == (6,) and s["buttons"].shape == (4,)
            time.sleep(0.01)
    finally:
        node.close()


def test_doctor_lists_joystick_event_devices(tmp_path):
    from rio_teleop.gamepad import doctor

    (tmp_path / "event7").write_text("")
    by_id = tmp_path / "by-id"
    by_id.mkdir()
    (by_id / "usb-Microsoft_Controller_3039-event-joystick").symlink_to(tmp_path / "event7")
    (by_id / "usb-Logitech_USB_Receiver-event-kbd").symlink_to(tmp_path / "event7")
    assert doctor.joystick_events(str(by_id), str(tmp_path / "none")) == [str(tmp_path / "event7")]
