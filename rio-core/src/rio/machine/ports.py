"""Serial ports on this machine (the USB adapters of servo buses, grippers, leader arms), for `rio ports`
and `rio find-port`.

`list_ports()` uses pyserial's `serial.tools.list_ports` when it is installed (every serial driver
plugin depends on it) and otherwise reads `/dev` and `/sys` itself: the `ttyUSB*` / `ttyACM*` devices
(macOS: `cu.usb*`), their USB vendor:product, serial number and names from sysfs. Either way each port
gets its stable `/dev/serial/by-id/...` path, the one to write in a station file: `/dev/ttyACM0` is
whichever adapter enumerated first, the by-id path names the adapter (vendor, product, serial number).

`find_port()` is LeRobot's `lerobot-find-port` made scriptable: compare the ports before and after the
user unplugs (or plugs in) the device; the one that changed is the device's. `scan(dev, sysfs)` reads
any directory laid out like `/dev` (tests point it at symlinks to pseudo-terminals: one that dangles is
an unplugged device, as a removed device node is).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from rio.errors import RioError

#: Device names of USB serial adapters: CDC-ACM (Feetech, Dynamixel U2D2's successors, Arduino), USB-serial
#: (FTDI, CH340, CP210x), and macOS's call-out devices.
PATTERNS = ("ttyUSB*", "ttyACM*", "cu.usbserial*", "cu.usbmodem*", "cu.SLAB_USBtoUART*", "cu.wchusbserial*")
#: How often the ports are listed while watching for a change.
POLL_S = 0.1
#: After the first change, how long to wait for the rest of it (a device with two ports loses both).
SETTLE_S = 0.3
#: After Enter: how long a port may take to go (the kernel removes it within milliseconds; udev's
#: by-id link a little later).
AFTER_ENTER_S = 2.0


@dataclass(frozen=True)
class SerialPort:
    """One serial port: its device path, stable by-id path and what its USB descriptor says."""

    device: str
    by_id: str | None = None
    vid: int | None = None
    pid: int | None = None
    serial_number: str | None = None
    description: str | None = None
    manufacturer: str | None = None

    @property
    def usb_id(self) -> str | None:
        """`vid:pid` in hex, as lsusb writes it (`1a86:55d3`)."""
        return None if self.vid is None or self.pid is None else f"{self.vid:04x}:{self.pid:04x}"

    @property
    def stable(self) -> str:
        """The path to write in a station file: by-id when there is one."""
        return self.by_id or self.device

    def to_json(self) -> dict[str, Any]:
        return {**asdict(self), "usb_id": self.usb_id}

    def summary(self) -> str:
        """`/dev/ttyACM0 (1a86:55d3, serial 5A46, USB Single Serial)`."""
        what = [x for x in (self.usb_id, self.serial_number and f"serial {self.serial_number}",
                            self.description) if x]
        return self.device + (f" ({', '.join(what)})" if what else "")


Lister = Callable[[], list[SerialPort]]


def list_ports(dev: str | Path | None = None, sysfs: str | Path | None = None) -> list[SerialPort]:
    """The serial ports, sorted by device: pyserial's list when it is installed, else `scan()`; a `dev`
    directory (or `sysfs`) other than the machine's always reads that directory with `scan()`."""
    if dev is None and sysfs is None:
        try:
            from serial.tools import list_ports as pyserial_ports
        except ImportError:
            pass
        else:
            return from_pyserial(pyserial_ports.comports(), Path("/dev"))
    return scan(Path(dev or "/dev"), Path(sysfs or "/sys"))


def from_pyserial(infos: Iterable[Any], dev: Path) -> list[SerialPort]:
    """pyserial's `ListPortInfo`s as `SerialPort`s, with their by-id paths from `dev`/serial/by-id."""
    by_id = _by_id(dev)
    out = []
    for p in infos:
        description = p.description if p.description and p.description != "n/a" else p.product
        out.append(SerialPort(p.device, by_id.get(os.path.realpath(p.device)), p.vid, p.pid,
                              p.serial_number or None, description or None, p.manufacturer or None))
    return sorted(out, key=lambda p: p.device)


def scan(dev: Path, sysfs: Path) -> list[SerialPort]:
    """The USB serial devices in `dev` (ttyUSB*, ttyACM*, ...): a name that leads nowhere (a dangling
    link) is no port. Their USB details from `sysfs`/class/tty/NAME/device, where present."""
    by_id = _by_id(dev)
    out = []
    seen = set()
    for pattern in PATTERNS:
        for path in dev.glob(pattern):
            if path in seen or not path.exists():
                continue
            seen.add(path)
            usb = _usb_attributes(sysfs / "class" / "tty" / path.name / "device")
            vid, pid = (_hex(usb.get("idVendor")), _hex(usb.get("idProduct")))
            out.append(SerialPort(str(path), by_id.get(os.path.realpath(path)), vid, pid, usb.get("serial"),
                                  usb.get("product") or usb.get("interface"), usb.get("manufacturer")))
    return sorted(out, key=lambda p: p.device)


def _by_id(dev: Path) -> dict[str, str]:
    """Resolved device -> its /dev/serial/by-id link (the udev rule that makes them: 60-serial.rules)."""
    folder = dev / "serial" / "by-id"
    try:
        links = sorted(folder.iterdir())
    except OSError:
        return {}
    return {os.path.realpath(link): str(link) for link in links if link.exists()}


def _usb_attributes(device: Path) -> dict[str, str]:
    """The USB descriptor strings of a tty's device in sysfs: the interface (ttyACM: the device link
    itself; ttyUSB: its parent) lies below the USB device, the first ancestor with an idVendor."""
    try:
        here = device.resolve(strict=True)
    except OSError:
        return {}
    attrs: dict[str, str] = {}
    interface = here / "interface"
    if interface.is_file():
        attrs["interface"] = _read(interface)
    for folder in (here, *list(here.parents)[:3]):
        if (folder / "idVendor").is_file():
            for key in ("idVendor", "idProduct", "serial", "product", "manufacturer"):
                if (folder / key).is_file():
                    attrs[key] = _read(folder / key)
            break
        if "interface" not in attrs and (folder / "interface").is_file():
            attrs["interface"] = _read(folder / "interface")
    return {k: v for k, v in attrs.items() if v}


def _read(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8", errors="replace").strip()
    except OSError:
        return ""


def _hex(text: str | None) -> int | None:
    try:
        return int(text, 16) if text else None
    except ValueError:
        return None


# -- which port is the device on? --------------------------------------------------------------------
@dataclass(frozen=True)
class Change:
    """Ports that went (`gone`) and came (`came`) between two listings."""

    gone: tuple[SerialPort, ...] = ()
    came: tuple[SerialPort, ...] = ()

    def __bool__(self) -> bool:
        return bool(self.gone or self.came)


def change(before: Sequence[SerialPort], after: Sequence[SerialPort]) -> Change:
    was, now = {p.device for p in before}, {p.device for p in after}
    return Change(tuple(p for p in before if p.device not in now), tuple(p for p in after if p.device not in was))


def wait_for_change(lister: Lister, before: Sequence[SerialPort], timeout: float,
                    came_only: bool = False) -> Change:
    """List the ports every POLL_S until they differ from `before` (with `came_only`: until a port is
    there that `before` lacks), then SETTLE_S more for the rest of the change; at most `timeout` s
    (an empty Change then)."""
    deadline = time.monotonic() + timeout
    while True:
        c = change(before, lister())
        if c.came if came_only else c:
            time.sleep(SETTLE_S)
            return change(before, lister())
        if time.monotonic() >= deadline:
            return Change()
        time.sleep(min(POLL_S, max(0.0, deadline - time.monotonic())))


def _names(ports: Sequence[SerialPort]) -> str:
    return ", ".join(p.device for p in ports) or "none"


def the_port(c: Change, before: Sequence[SerialPort]) -> tuple[str, SerialPort]:
    """The one port that changed: ('unplugged', port) or ('plugged', port); a RioError saying what to
    do when none or several did."""
    if len(c.gone) == 1:
        return "unplugged", c.gone[0]
    if len(c.gone) > 1:
        raise RioError(f"several ports disappeared ({_names(c.gone)}): unplug only the one device, or a device "
                       "with several ports is ambiguous; try again")
    if len(c.came) == 1:
        return "plugged", c.came[0]
    if len(c.came) > 1:
        raise RioError(f"several ports appeared ({_names(c.came)}): plug in only the one device; try again")
    raise RioError(f"no serial port disappeared or appeared (ports: {_names(before)}): is the device connected "
                   "by USB, and was its cable unplugged? (`rio ports` lists them)")
