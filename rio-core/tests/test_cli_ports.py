"""`rio ports` and `rio find-port` against serial devices that come and go: pseudo-terminals (real tty
devices, `rio.emulation.PtyDevice`) behind a /dev-like directory of `ttyACM*` and `serial/by-id` links
and a sysfs-like tree with their USB descriptors. Plugging in opens a pty and makes the links, as udev
does; unplugging closes it and removes them. The listing code reads that directory exactly as it reads
/dev (`rio.machine.ports.scan`); only where it looks is changed."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from rio.cli.app import build_app
from rio.emulation import PtyDevice
from rio.machine import ports

APP = build_app(load_plugins=False)
FEETECH = {"vid": "1a86", "pid": "55d3", "serial": "5A46083210", "product": "USB Single Serial",
           "manufacturer": "QinHeng"}


class Usb:
    """A /dev and /sys of USB serial adapters on pseudo-terminals."""

    def __init__(self, root: Path):
        self.dev, self.sys = root / "dev", root / "sys"
        (self.dev / "serial" / "by-id").mkdir(parents=True)
        (self.sys / "class" / "tty").mkdir(parents=True)
        self.ptys: dict[str, PtyDevice] = {}
        #: set when the command first lists the ports: the user acts after the command has looked
        self.listed = threading.Event()

    def by_id(self, name: str, serial: str) -> Path:
        return self.dev / "serial" / "by-id" / f"usb-1a86_USB_Single_Serial_{serial}-if00"

    def plug(self, name: str = "ttyACM0", bus: str = "1-1", **usb: str) -> PtyDevice:
        desc = {**FEETECH, **usb}
        pty = PtyDevice(start=False)
        self.ptys[name] = pty
        usb_dev = self.sys / "devices" / "usb1" / bus
        (usb_dev / f"{bus}:1.0").mkdir(parents=True, exist_ok=True)
        for key, value in (("idVendor", desc["vid"]), ("idProduct", desc["pid"]), ("serial", desc["serial"]),
                           ("product", desc["product"]), ("manufacturer", desc["manufacturer"])):
            (usb_dev / key).write_text(value + "\n")
        (self.sys / "class" / "tty" / name).mkdir(exist_ok=True)
        (self.sys / "class" / "tty" / name / "device").symlink_to(usb_dev / f"{bus}:1.0")
        (self.dev / name).symlink_to(pty.port)
        self.by_id(name, desc["serial"]).symlink_to(Path("..", "..", name))
        return pty

    def unplug(self, name: str = "ttyACM0") -> None:
        self.ptys.pop(name).close()
        for link in (self.dev / name, self.sys / "class" / "tty" / name / "device",
                     *[p for p in (self.dev / "serial" / "by-id").iterdir() if os.readlink(p).endswith(name)]):
            link.unlink()

    def lister(self) -> list[ports.SerialPort]:
        found = ports.scan(self.dev, self.sys)
        self.listed.set()
        return found

    def close(self) -> None:
        for pty in self.ptys.values():
            pty.close()


@pytest.fixture
def usb(tmp_path, monkeypatch):
    u = Usb(tmp_path)
    monkeypatch.setattr(ports, "list_ports", u.lister)  # what `rio ports` / `rio find-port` list
    yield u
    u.close()


def later(usb: Usb, seconds: float, *actions) -> threading.Thread:
    """The user, `seconds` after the command first listed the ports (a loaded machine may take longer than
    that to get there): unplugging, plugging in."""

    def act() -> None:
        usb.listed.wait(60.0)
        time.sleep(seconds)
        for a in actions:
            a()

    t = threading.Thread(target=act, daemon=True)
    t.start()
    return t


def invoke(*args: str):
    return CliRunner().invoke(APP, list(args), catch_exceptions=False)


# --- the listing -------------------------------------------------------------------------------------


def test_scan_reads_devices_by_id_and_usb_descriptors(tmp_path):
    u = Usb(tmp_path)
    try:
        u.plug("ttyACM0")
        u.plug("ttyUSB0", bus="1-2", vid="0403", pid="6014", serial="FT1", product="FT232H", manufacturer="FTDI")
        (u.dev / "ttyACM7").symlink_to(tmp_path / "gone")  # a dangling name is no port
        (u.dev / "ttyS0").touch()  # not a USB adapter
        found = ports.list_ports(u.dev, u.sys)
        assert [p.device for p in found] == [str(u.dev / "ttyACM0"), str(u.dev / "ttyUSB0")]
        acm, ftdi = found
        assert (acm.usb_id, acm.serial_number, acm.description, acm.manufacturer) == (
            "1a86:55d3", "5A46083210", "USB Single Serial", "QinHeng")
        assert acm.by_id == str(u.by_id("ttyACM0", "5A46083210")) == acm.stable
        assert (ftdi.usb_id, ftdi.by_id) == ("0403:6014", str(u.by_id("ttyUSB0", "FT1")))
        assert acm.to_json()["usb_id"] == "1a86:55d3" and acm.to_json()["device"] == acm.device
        u.unplug("ttyACM0")
        assert [p.device for p in ports.list_ports(u.dev, u.sys)] == [str(u.dev / "ttyUSB0")]
    finally:
        u.close()


def test_a_closed_device_is_gone_even_while_its_links_remain(tmp_path):
    """The kernel removes a device node before udev removes its links: a link that dangles lists nothing."""
    u = Usb(tmp_path)
    pty = u.plug("ttyACM0")
    assert len(u.lister()) == 1
    pty.close()
    assert u.lister() == []


def test_pyserial_ports_get_their_by_id_path(tmp_path):
    from serial.tools.list_ports_common import ListPortInfo

    u = Usb(tmp_path)
    try:
        u.plug("ttyACM0")
        info = ListPortInfo(str(u.dev / "ttyACM0"), skip_link_detection=True)
        info.vid, info.pid, info.serial_number, info.product = 0x1A86, 0x55D3, "5A46083210", "USB Single Serial"
        (port,) = ports.from_pyserial([info], u.dev)
        assert (port.usb_id, port.description, port.by_id) == (
            "1a86:55d3", "USB Single Serial", str(u.by_id("ttyACM0", "5A46083210")))
    finally:
        u.close()


def test_machine_listing_is_pyserials_or_a_scan_of_dev(monkeypatch):
    from serial.tools.list_ports import comports

    from rio.testing import block_import

    assert [p.device for p in ports.list_ports()] == sorted(p.device for p in comports())
    block_import(monkeypatch, "serial")
    assert ports.list_ports() == ports.scan(Path("/dev"), Path("/sys"))


def test_rio_ports_table_and_json(usb):
    usb.plug("ttyACM0")
    r = invoke("ports")
    assert r.exit_code == 0 and "ttyACM0" in r.stdout and "1a86:55d3" in r.stdout, r.output
    r = invoke("ports", "--json")
    (entry,) = json.loads(r.stdout)
    assert entry["device"].endswith("ttyACM0") and entry["by_id"].endswith("5A46083210-if00")
    assert (entry["usb_id"], entry["serial_number"]) == ("1a86:55d3", "5A46083210")
    usb.unplug("ttyACM0")
    assert json.loads(invoke("ports", "--json").stdout) == []
    assert "no serial port found" in invoke("ports").stdout


# --- find-port ---------------------------------------------------------------------------------------


def test_find_port_watches_for_the_port_that_disappears(usb):
    usb.plug("ttyACM0")
    usb.plug("ttyACM1", bus="1-2", serial="OTHER")
    later(usb, 0.3, lambda: usb.unplug("ttyACM1"))
    r = invoke("find-port", "--timeout", "10")
    assert r.exit_code == 0, r.output
    assert f"the device's port is {usb.dev / 'ttyACM1'}" in r.stdout
    assert f'port = "{usb.by_id("ttyACM1", "OTHER")}"' in r.stdout
    assert "Plug the cable back in" in r.stderr


def test_find_port_json_and_a_device_plugged_in(usb):
    later(usb, 0.3, lambda: usb.plug("ttyACM0"))
    r = invoke("find-port", "--timeout", "10", "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert out["event"] == "plugged" and out["port"]["device"] == str(usb.dev / "ttyACM0")
    assert out["port"]["usb_id"] == "1a86:55d3" and out["replugged"] is None


def test_find_port_replug_reports_where_the_device_came_back(usb):
    """Unplugged, then back in, on another name (ttyACM0 -> ttyACM1, as Linux does when the old name is
    still held): the by-id path, which does not change, is what to write."""
    usb.plug("ttyACM0")
    later(usb, 0.3, lambda: usb.unplug("ttyACM0"), lambda: time.sleep(0.5), lambda: usb.plug("ttyACM1", bus="1-3"))
    r = invoke("find-port", "--timeout", "10", "--replug", "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert (out["event"], out["port"]["device"], out["replugged"]["device"]) == (
        "unplugged", str(usb.dev / "ttyACM0"), str(usb.dev / "ttyACM1"))
    assert out["replugged"]["by_id"] == out["port"]["by_id"]


def test_find_port_times_out_in_one_line(usb):
    usb.plug("ttyACM0")
    r = invoke("find-port", "--timeout", "0.3")
    assert r.exit_code == 1
    assert r.stderr.splitlines()[-1].startswith("error: no serial port disappeared or appeared within 0.3 s")
    assert "Traceback" not in r.output


def test_find_port_replug_that_never_comes_back(usb):
    usb.plug("ttyACM0")
    later(usb, 0.2, lambda: usb.unplug("ttyACM0"))
    r = invoke("find-port", "--timeout", "1", "--replug")
    assert r.exit_code == 1 and r.stderr.splitlines()[-1] == "error: the device did not come back within 1 s"


def test_find_port_two_ports_gone_is_ambiguous(usb):
    usb.plug("ttyACM0")
    usb.plug("ttyACM1", bus="1-2", serial="OTHER")
    later(usb, 0.2, lambda: usb.unplug("ttyACM0"), lambda: usb.unplug("ttyACM1"))
    r = invoke("find-port", "--timeout", "5")
    assert r.exit_code == 1 and "several ports disappeared" in r.stderr.splitlines()[-1]


def test_find_port_without_enter_says_to_use_timeout(usb):
    usb.plug("ttyACM0")
    r = CliRunner().invoke(APP, ["find-port"], input="")
    assert r.exit_code == 1 and "rio find-port --timeout" in r.stderr.splitlines()[-1]


def _rio_with_ports_in(usb: Usb, *args: str) -> subprocess.Popen:
    """`rio ARGS` in its own process, listing `usb`'s directories instead of /dev and /sys."""
    code = ("import functools, sys; from rio.machine import ports; "
            f"ports.list_ports = functools.partial(ports.list_ports, {str(usb.dev)!r}, {str(usb.sys)!r}); "
            f"from rio.cli import main; sys.exit(main({list(args)!r}))")
    return subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env={**os.environ, "RIO_LOAD_PLUGINS": ""})


def _wait_for_line(p: subprocess.Popen, text: str) -> None:
    assert p.stderr is not None
    while text not in (line := p.stderr.readline()):
        assert line, f"rio ended before saying {text!r}"


def test_find_port_interactive_unplug_then_enter(usb):
    """LeRobot's flow, in a real process: the ports are listed, the user is asked to unplug and press
    Enter, and the port that went is the answer."""
    usb.plug("ttyACM0")
    usb.plug("ttyACM1", bus="1-2", serial="OTHER")
    p = _rio_with_ports_in(usb, "find-port")
    _wait_for_line(p, "then press Enter")
    usb.unplug("ttyACM0")
    out, err = p.communicate("\n", timeout=30)
    assert p.returncode == 0, err
    assert f"the device's port is {usb.dev / 'ttyACM0'} (1a86:55d3, serial 5A46083210" in out
    assert "Traceback" not in err


def test_find_port_interactive_replug(usb):
    usb.plug("ttyACM0")
    p = _rio_with_ports_in(usb, "find-port", "--replug")
    _wait_for_line(p, "then press Enter")
    usb.unplug("ttyACM0")
    assert p.stdin is not None
    p.stdin.write("\n")
    p.stdin.flush()
    _wait_for_line(p, "Plug the cable back in; waiting")
    usb.plug("ttyACM0")
    out, err = p.communicate(timeout=30)
    assert p.returncode == 0, err
    assert f"it came back on {usb.dev / 'ttyACM0'}" in out
