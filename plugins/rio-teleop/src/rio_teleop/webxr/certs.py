"""The WebXR page's TLS certificate: browsers open WebXR and motion sensors only on secure pages, so
the page is served over HTTPS with a self-signed certificate made on first use.

It lives in `$XDG_CONFIG_HOME/rio/webxr/` (`~/.config/rio/webxr/`): `cert.pem` and `key.pem` (0600).
It is reused while it is valid and names every address asked for, so its fingerprint stays the same
across restarts (a headset that trusted it once keeps trusting it); it is made again when it expires,
is about to, or lacks an address the page is now served on. The fingerprint (SHA-256 of the
certificate, as browsers show it) is printed with the page's address so the operator can compare it
with what the headset's browser shows before accepting it.
"""

from __future__ import annotations

import datetime
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

DAYS = 825  # what Apple's platforms accept for a TLS server certificate
RENEW_BEFORE = datetime.timedelta(days=1)


@dataclass(frozen=True)
class Certificate:
    cert: Path
    key: Path
    fingerprint: str  # SHA-256, colon-separated upper-case hex (as browsers show it)
    not_after: datetime.datetime
    names: tuple[str, ...]  # DNS names and IP addresses it is valid for


def default_dir() -> Path:
    from rio.machine.calibration_files import config_home

    return config_home() / "webxr"


def ensure_certificate(directory: str | os.PathLike[str] | None = None, names: list[str] | tuple[str, ...] = (),
                       days: int = DAYS, now: datetime.datetime | None = None) -> Certificate:
    """The certificate in `directory` (default `default_dir()`), made or made again when missing,
    unreadable, expired (or within a day of it), or not naming every one of `names` (host names or
    IP addresses; `localhost` and 127.0.0.1 are always included)."""
    d = Path(os.path.expanduser(os.fspath(directory))) if directory is not None else default_dir()
    now = now or datetime.datetime.now(datetime.timezone.utc)
    wanted = _names(names)
    cert_file, key_file = d / "cert.pem", d / "key.pem"
    current = _read(cert_file, key_file)
    if current is not None and current.not_after - RENEW_BEFORE > now and set(wanted) <= set(current.names):
        return current
    keep = current.names if current is not None else ()
    all_names = tuple(dict.fromkeys([*wanted, *keep]))  # a renewed certificate keeps the old names
    d.mkdir(parents=True, exist_ok=True, mode=0o700)
    key_pem, cert_pem = _make(all_names, days, now)
    _replace(key_file, key_pem, secret=True)
    _replace(cert_file, cert_pem)
    made = _read(cert_file, key_file)
    assert made is not None
    return made


def fingerprint(cert: Any) -> str:
    from cryptography.hazmat.primitives import hashes

    return ":".join(f"{b:02X}" for b in cert.fingerprint(hashes.SHA256()))


def _names(names: list[str] | tuple[str, ...]) -> tuple[str, ...]:
    out = ["localhost", "127.0.0.1"]
    for n in names:
        n = n.strip()
        if n and n not in ("0.0.0.0", "::") and n not in out:
            out.append(n)
    return tuple(out)


def _read(cert_file: Path, key_file: Path) -> Certificate | None:
    from cryptography import x509
    from cryptography.hazmat.primitives import serialization

    if not (cert_file.is_file() and key_file.is_file()):
        return None
    try:
        cert = x509.load_pem_x509_certificate(cert_file.read_bytes())
        key = serialization.load_pem_private_key(key_file.read_bytes(), password=None)
    except (ValueError, TypeError, OSError):
        return None  # damaged: made again
    if cert.public_key().public_numbers() != key.public_key().public_numbers():  # type: ignore[union-attr]
        return None
    try:
        san = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    except x509.ExtensionNotFound:
        return None
    names = tuple([*san.get_values_for_type(x509.DNSName), *(str(a) for a in san.get_values_for_type(x509.IPAddress))])
    return Certificate(cert_file, key_file, fingerprint(cert), cert.not_valid_after_utc, names)


def _make(names: tuple[str, ...], days: int, now: datetime.datetime) -> tuple[bytes, bytes]:
    from rio.machine.keys import self_signed

    return self_signed("rio teleop webxr", list(names), days, now)


def _replace(path: Path, data: bytes, secret: bool = False) -> None:
    """Write next to `path` and rename over it (a crash leaves the old file or the new one)."""
    tmp = path.with_name(path.name + ".tmp")
    try:
        tmp.unlink()
    except FileNotFoundError:
        pass
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600 if secret else 0o644)
    with os.fdopen(fd, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
