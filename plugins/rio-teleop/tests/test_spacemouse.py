"""teleop.spacemouse on recorded HID reports.

There is no SpaceMouse (and no /dev/uinput or /dev/hidraw) on CI, so the reports are built byte for
byte as the device sends them, per pyspacemouse's device table: a SpaceMouse Compact sends report 1
(translation x, y, z: int16 little-endian), report 2 (rotation Rx, Ry, Rz) and report 3 (a button
bitmask); a SpaceMouse Wireless sends all six axes in report 1. Raw axes are in the HID frame (+x
right, +y toward you, +z down; about 350 counts at full deflection). Only the HID layer is faked:
easyhid's `Enumeration` and device object (`FakeHid.read()` returns the next report, zero-padded
to the requested size as hidapi does). pyspacemouse's own `open()`, axis convention and report
parsing (`SpaceMouseDevice.read()`) run unchanged, and so does the node.
"""

from __future__ import annotations

import time
import types
from contextlib import contextmanager
from unittest import mock

import numpy as np
import pyspacemouse.api
import pytest
from rio_teleop.spacemouse.driver import SpaceMouseTeleop

from rio.conformance.drivers import TeleopConformance
from rio.control.teleop import BUTTON_DISCARD, BUTTON_DONE, BUTTON_KEEP, BUTTON_MODE
from rio.errors import RioError
from rio.testing import fake_eef_station

COMPACT = (0x256F, 0xC635)
WIRELESS = (0x256F, 0xC62E)
FULL = 350  # counts at full deflection (pyspacemouse's axis_scale)


def i16(v: int) -> list[int]:
    return list(int(v).to_bytes(2, "little", signed=True))


def compact_translation(x=0, y=0, z=0) -> bytes:
    return bytes([1, *i16(x), *i16(y), *i16(z)])


def compact_rotation(rx=0, ry=0, rz=0) -> bytes:
    return bytes([2, *i16(rx), *i16(ry), *i16(rz)])


def wireless_motion(x=0, y=0, z=0, rx=0, ry=0, rz=0) -> bytes:
    return bytes([1, *i16(x), *i16(y), *i16(z), *i16(rx), *i16(ry), *i16(rz)])


def button_report(left=False, right=False) -> bytes:
    return bytes([3, int(left) | int(right) << 1, 0])


BATTERY = bytes([0x17, 0x5F])  # a SpaceMouse Wireless's battery report: matches no channel, changes nothing


class FakeHid:
    """easyhid's HIDDevice, replaying reports. `timeline`: (seconds after open, report) pairs;
    `read()` returns the next report once its time has come, else nothing (non-blocking)."""

    def __init__(self, ids, timeline=(), path="/dev/hidraw7"):
        self.vendor_id, self.product_id = ids
        self.path, self.product_string, self.manufacturer_string = path, "SpaceMouse", "3Dconnexion"
        self.release_number, self.serial_number = 0x0437, "00000000"
        self.timeline, self.t0, self.closed, self.unplugged = list(timeline), None, False, False

    def feed(self, *reports: bytes) -> None:
        self.timeline += [(0.0, r) for r in reports]

    def open(self):
        self.t0 = time.monotonic()

    def set_nonblocking(self, flag):
        assert flag is True

    def read(self, size=64, timeout=None):
        if self.unplugged:
            from easyhid import HIDException

            raise HIDException("Failed to read from HID device: -1")
        if not self.timeline or self.timeline[0][0] > time.monotonic() - self.t0:
            return bytearray()
        report = self.timeline.pop(0)[1]
        return bytearray(report[:size].ljust(size, b"\0"))

    def close(self):
        self.closed = True


@pytest.fixture
def plugged(monkeypatch):
    """Plug fake HID devices in: `plugged(FakeHid(...), ...)`."""
    def plug(*devices):
        enum = types.SimpleNamespace(find=lambda *a, **k: list(devices), device_list=list(devices))
        monkeypatch.setattr(pyspacemouse.api, "Enumeration", lambda *a, **k: enum)
        return devices[0] if devices else None
    return plug


def opened(**config) -> SpaceMouseTeleop:
    node = SpaceMouseTeleop(**config)
    node.open()
    return node


def test_compact_push_lift_and_twist_map_to_the_base_frame(plugged):
    hid = plugged(FakeHid(COMPACT))
    node = opened(speed=0.1, rot_speed=0.8, deadband=0.1)
    assert node.input.label == "SpaceMouse SpaceMouseCompact"
    hid.feed(compact_translation(y=-FULL), compact_rotation())  # cap pushed away from you, fully
    assert np.allclose(node.read_state()["twist"], [0.1, 0, 0, 0, 0, 0])
    hid.feed(compact_translation(x=-FULL // 2, z=-FULL))  # half left, fully up; rotation report unchanged
    s = node.read_state()["twist"]
    assert s[0] == 0 and s[1] == pytest.approx(0.1 * (0.5 - 0.1) / 0.9, abs=1e-3) and s[2] == pytest.approx(0.1)
    hid.feed(compact_translation(), compact_rotation(rz=-FULL))  # twisted counter-clockwise seen from above
    assert np.allclose(node.read_state()["twist"], [0, 0, 0, 0, 0, 0.8])
    hid.feed(compact_rotation(rx=FULL))  # top tilted toward you: about the base y axis, negative
    assert np.allclose(node.read_state()["twist"], [0, 0, 0, 0, -0.8, 0])
    hid.feed(compact_rotation(ry=FULL))  # top tilted left: roll about x, negative
    assert np.allclose(node.read_state()["twist"], [0, 0, 0, -0.8, 0, 0])
    node.close()
    assert hid.closed


def test_deadband_holds_a_resting_hand_still_and_output_starts_at_zero(plugged):
    hid = plugged(FakeHid(COMPACT))
    node = opened(deadband=0.15)
    hid.feed(compact_translation(x=20, y=-30, z=40), compact_rotation(rx=-25, ry=10, rz=50))  # < 0.15 * 350
    assert np.allclose(node.read_state()["twist"], 0)
    hid.feed(compact_translation(y=-int(0.16 * FULL)))  # just past it: a small speed, no jump
    assert 0 < node.read_state()["twist"][0] < 0.01


def test_axis_mapping_and_scale_for_a_robot_facing_you(plugged):
    hid = plugged(FakeHid(COMPACT))
    node = opened(axes=["-x", "-y", "z", "-roll", "-pitch", "yaw"], scale=[2, 1, 1, 1, 1, 0], deadband=0)
    hid.feed(compact_translation(x=FULL, y=-FULL), compact_rotation(rx=FULL, rz=-FULL))
    tw = node.read_state()["twist"]
    assert np.allclose(tw, [-0.2, 0.1, 0, 0, 0.8, 0])  # push away -> toward the robot's -x; yaw scaled off


def test_compact_buttons_gripper_toggle_and_latched_done(plugged):
    hid = plugged(FakeHid(COMPACT))
    node = opened()
    assert node.read_state()["gripper"] == 1.0  # open at start
    hid.feed(button_report(left=True), button_report())  # a tap shorter than a cycle still toggles
    assert node.read_state()["gripper"] == 0.0
    hid.feed(button_report(left=True))
    s = node.read_state()
    assert s["gripper"] == 1.0 and not s["buttons"].any()
    hid.feed(button_report(right=True), button_report())
    b = node.read_state()["buttons"]
    assert b[BUTTON_DONE] and not b[BUTTON_KEEP] and not b[BUTTON_DISCARD] and not b[BUTTON_MODE]
    assert node.read_state()["buttons"][BUTTON_DONE]  # latched, as the keyboard's q
    node.reset()
    assert not node.read_state()["buttons"].any()
    assert "LEFT gripper" in node.help() and "RIGHT done" in node.help()


def test_wireless_single_report_battery_ignored_and_rebound_keys(plugged):
    hid = plugged(FakeHid(WIRELESS))
    node = opened(keys={"gripper": "RIGHT", "keep": "LEFT", "done": ""}, buttons=4, deadband=0.1)
    assert node.input.label == "SpaceMouse SpaceMouseWireless"
    hid.feed(wireless_motion(y=FULL, rz=FULL), BATTERY)  # pulled toward you, twisted clockwise
    assert np.allclose(node.read_state()["twist"], [-0.1, 0, 0, 0, 0, -0.8])
    hid.feed(button_report(right=True), button_report(), button_report(left=True))
    s = node.read_state()
    assert s["gripper"] == 0.0 and s["buttons"][BUTTON_DONE] and s["buttons"][BUTTON_KEEP]
    assert not s["buttons"][BUTTON_DISCARD]


def test_buttons_published_follow_the_configured_count(plugged):
    hid = plugged(FakeHid(COMPACT))
    node = opened(buttons=2)
    hid.feed(button_report(right=True))
    assert node.read_state()["buttons"].tolist() == [False, True]


def test_unknown_button_names_the_device_and_its_buttons(plugged):
    hid = plugged(FakeHid(COMPACT))
    with pytest.raises(RioError, match=r"SpaceMouseCompact has no button 'BTN_3'; its buttons: LEFT, RIGHT"):
        opened(keys={"keep": "BTN_3"})
    assert hid.closed
    with pytest.raises(RioError, match="has no axis 'left_x'"):
        opened(axes=["left_x", "y", "z", "roll", "pitch", "yaw"])


def test_not_plugged_in_says_which_device_and_the_udev_rule(plugged):
    plugged()  # hidapi answers, no SpaceMouse
    with pytest.raises(RioError) as e:
        opened()
    msg = str(e.value)
    assert "teleop.spacemouse: no 3Dconnexion SpaceMouse found" in msg and "Plug it in" in msg
    assert 'ATTRS{idVendor}=="256f"' in msg and "udevadm" in msg
    with pytest.raises(RioError, match="no SpaceMouseWireless found"):
        opened(device="SpaceMouseWireless")


def test_plugged_in_but_not_permitted_points_to_the_udev_rule(plugged):
    from easyhid import HIDException

    hid = plugged(FakeHid(COMPACT))

    def denied():  # what easyhid raises when hid_open_path fails (no udev rule: /dev/hidraw* is root's)
        raise HIDException("Failed to open device")

    hid.open = denied
    with pytest.raises(RioError, match=r"(?s)found 3Dconnexion SpaceMouse but may not open it; .*99-spacemouse"):
        opened()


def test_missing_hidapi_library_says_what_to_install(monkeypatch):
    def no_library(*a, **k):  # what easyhid's Enumeration raises when libhidapi is not installed
        raise AttributeError("function/symbol 'hid_enumerate' not found in library '<None>'")

    monkeypatch.setattr(pyspacemouse.api, "Enumeration", no_library)
    for device in (None, "SpaceMouseCompact"):
        with pytest.raises(RioError, match="apt install libhidapi-hidraw0"):
            opened(device=device)


def test_unknown_model_lists_pyspacemouse_models():
    with pytest.raises(RioError, match="SpaceMouseCompact"):
        opened(device="SpaceBall5000")


def test_unplugged_while_running_is_named(plugged):
    hid = plugged(FakeHid(COMPACT))
    node = opened()
    hid.unplugged = True
    with pytest.raises(RioError, match="SpaceMouseCompact stopped answering"):
        node.read_state()


class TestSpaceMouseConformance(TeleopConformance):
    """The teleop driver kit on a SpaceMouse Compact whose HID layer is faked (reports waiting)."""

    driver = "rio_teleop.spacemouse.driver:SpaceMouseTeleop"
    bad_config = {"device": "SpaceMouseWireless"}  # not the one plugged in

    @contextmanager
    def emulator(self):
        hid = FakeHid(COMPACT, [(0.0, compact_translation(y=-FULL)), (0.0, compact_rotation(rz=100)),
                                (0.05, button_report(left=True)), (0.1, button_report(right=True))])
        enum = types.SimpleNamespace(find=lambda *a, **k: [hid], device_list=[hid])
        with mock.patch.object(pyspacemouse.api, "Enumeration", lambda *a, **k: enum):
            yield {}


STATION = fake_eef_station("spacemouse-eef", 'driver = "teleop.spacemouse"\nspeed = 0.1', dof=3)


def test_recorded_stream_drives_rio_teleop_on_a_fake_arm(plugged, tmp_path):
    from rio.workflows.teleop import run_teleop

    timeline = [(0.3, compact_translation(y=-FULL)), (0.3, compact_rotation()),  # push away 0.6 s
                (0.9, compact_translation()),                                    # let go
                (0.9, button_report(left=True)), (1.0, button_report()),         # close the gripper
                (1.4, button_report(right=True)), (1.5, button_report())]        # done
    plugged(FakeHid(COMPACT, timeline))
    station = tmp_path / "sm.toml"
    station.write_text(STATION)
    poses, grips = [], []

    def on_tick(tick):
        arm = tick.info["arms"][0]
        poses.append(np.asarray(arm.client.get_state()["eef_pose"][:3], dtype=float))  # measured, not the target
        grips.append(arm.gripper_cmd)

    summary = run_teleop(str(station), duration=8.0, on_tick=on_tick, log=None)
    assert summary.reason == "the device finished", summary.format()
    moved = poses[-1] - poses[0]
    assert 0.04 < moved[0] < 0.08 and abs(moved[1]) < 1e-3 and abs(moved[2]) < 1e-3  # ~0.1 m/s for 0.6 s, +x
    assert grips[-1] == 0.0 < grips[0]


@pytest.mark.hardware
def test_real_spacemouse_opens_and_reads():
    """A SpaceMouse plugged into this machine: opens, reads for a second, publishes the layout."""
    node = opened()
    try:
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            s = node.read_state()
            assert s["twist"].shape == (6,) and s["buttons"].shape == (4,)
            time.sleep(0.01)
    finally:
        node.close()


def test_doctor_finds_spacemice_in_sysfs_and_names_what_is_missing(tmp_path, monkeypatch):
    from rio_teleop.spacemouse import doctor

    for n, hid_id in (("hidraw0", "0003:0000046D:0000C52B"), ("hidraw3", "0003:0000256F:0000C635"),
                      ("hidraw4", "0005:0000256F:0000C638"), ("hidraw5", "0003:0000046D:0000C626")):
        (tmp_path / n / "device").mkdir(parents=True)
        (tmp_path / n / "device" / "uevent").write_text(f"DRIVER=hid-generic\nHID_ID={hid_id}\nHID_NAME=x\n")
    # a Logitech receiver is not a SpaceMouse; 3Dconnexion over USB and Bluetooth, and a SpaceNavigator are
    assert doctor.spacemouse_hidraw(str(tmp_path)) == ["/dev/hidraw3", "/dev/hidraw4", "/dev/hidraw5"]
    monkeypatch.setattr(doctor, "hidapi_library", lambda: None)
    assert "libhidapi-hidraw0" in doctor.hid_problem()
