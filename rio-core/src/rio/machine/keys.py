"""Keys for stations whose nodes talk across machines: one directory per machine, made by
`rio keys generate`, named in the station file as `[middleware] keys = "..."`.

Why one directory per machine: every machine of a station reads the *same* station file, so the file
names a path (`~/.config/rio/keys/lab`) and each machine holds its own keys at that path. A machine's
directory holds its own secrets and only what it needs to recognise the others:

    <machine>/
      identity              the machine's name (its TLS certificate's common name and zmq key name)
      ca.pem                the station's certificate authority (trust anchor for TLS, zenoh)
      tls.pem, tls.key      this machine's certificate, signed by that CA, and its private key
      curve.key_secret      this machine's zmq CURVE key pair (public + secret, zmq's certificate format)
      peers/<name>.key      every machine's CURVE public key: who a zmq node lets in

The CA's own private key stays in `<dir>/ca/` on the machine that ran `generate` (it signs machines
added later with `rio keys add`); it is never needed to run a station. Secret files are written
0600 and refused when others can read them, like ssh does.
"""

from __future__ import annotations

import contextlib
import datetime
import ipaddress
import os
import re
import shutil
import stat
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rio.errors import ConfigError

NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_\-]{0,62}$")
_CA_DIR = "ca"
_DAYS = 3650
#: Longest validity a certificate gets (100 years): a certificate cannot end after 9999-12-31, and the date
#: arithmetic overflowed (a traceback) for `--days 99999999`.
MAX_DAYS = 36500
#: One label of a host name (RFC 1123): letters, digits and '-' inside, 1 to 63 characters.
_LABEL = re.compile(r"^[A-Za-z0-9](?:[A-Za-z0-9-]{0,61}[A-Za-z0-9])?$")


@dataclass(frozen=True)
class MachineKeys:
    """One machine's keys, checked: every file present, secrets private."""

    dir: Path
    identity: str
    ca: Path
    tls_cert: Path
    tls_key: Path
    curve_secret: Path
    #: name -> that machine's zmq CURVE public key (z85 bytes)
    peers: dict[str, bytes] = field(default_factory=dict)

    def curve_keypair(self) -> tuple[bytes, bytes]:
        """(public, secret) z85 keys of this machine."""
        import zmq.auth

        public, secret = zmq.auth.load_certificate(str(self.curve_secret))
        if secret is None:
            raise ConfigError(f"{self.curve_secret}: holds no secret key (is it a public .key file?)")
        return public, secret

    def peer(self, name: str) -> bytes:
        """The CURVE public key of machine `name`, from this machine's `peers/` (never from the network)."""
        try:
            return self.peers[name]
        except KeyError:
            raise ConfigError(f"{self.dir}: no peers/{name}.key: machine '{name}' is not one this machine "
                              f"trusts (known: {', '.join(sorted(self.peers)) or 'none'}); "
                              f"run `rio keys add` and copy the new directories") from None


def load(path: str | os.PathLike[str]) -> MachineKeys:
    """A machine's keys directory, checked; ConfigError naming the file otherwise."""
    d = Path(os.path.expanduser(os.fspath(path)))
    if not d.is_dir():
        raise ConfigError(f"keys directory {d} does not exist: make one with `rio keys generate DIR --name "
                          f"<machine>` and copy DIR/<machine> to each machine")
    ident_file = d / "identity"
    if not ident_file.is_file():
        hint = (" (this looks like the directory `generate` made: name one machine's directory in it)"
                if (d / _CA_DIR).is_dir() else "")
        raise ConfigError(f"{d}: no 'identity' file: not a machine's keys directory{hint}")
    identity = ident_file.read_text(encoding="utf-8", errors="replace").strip()
    if not NAME.match(identity):
        raise ConfigError(f"{ident_file}: '{identity[:40]}' is not a machine name")
    files = {n: d / n for n in ("ca.pem", "tls.pem", "tls.key", "curve.key_secret")}
    for f in files.values():
        if not f.is_file():
            raise ConfigError(f"{d}: missing {f.name} (regenerate this machine with `rio keys add`)")
    for secret in (files["tls.key"], files["curve.key_secret"]):
        check_private(secret)
    peers: dict[str, bytes] = {}
    for p in sorted((d / "peers").glob("*.key")):
        peers[p.stem] = _read_public(p)
    if identity not in peers:
        raise ConfigError(f"{d}: peers/{identity}.key (this machine's own public key) is missing")
    return MachineKeys(d, identity, files["ca.pem"], files["tls.pem"], files["tls.key"],
                       files["curve.key_secret"], peers)


def check_private(path: Path) -> None:
    """Refuse a secret file that other users can read (as ssh does)."""
    if os.name != "posix":
        return  # Windows ACLs: not checked here
    mode = path.stat().st_mode
    if mode & (stat.S_IRWXG | stat.S_IRWXO):
        raise ConfigError(f"{path} is readable by other users (mode {stat.S_IMODE(mode):04o}): "
                          f"`chmod 600 {path}` (a secret key others can read is no secret)")


def _read_public(path: Path) -> bytes:
    import zmq.auth

    try:
        public, _ = zmq.auth.load_certificate(str(path))
    except (ValueError, OSError) as e:
        raise ConfigError(f"{path}: not a zmq public key file ({e})") from None
    return public


# -- making keys ---------------------------------------------------------------------------------------
def generate(out: str | os.PathLike[str], names: list[str], addresses: dict[str, list[str]] | None = None,
             days: int = _DAYS) -> list[Path]:
    """A new station CA in `out/ca/` and a directory per machine; returns the machine directories.
    Refuses an `out` that already holds a CA (use `add`)."""
    root = Path(os.path.expanduser(os.fspath(out)))
    if (root / _CA_DIR).exists():
        raise ConfigError(f"{root} already holds a station CA: add machines with `rio keys add {root} --name ...`")
    _check_request(names, addresses, days)  # everything that can be refused, before anything is written
    if root.exists() and not root.is_dir():
        raise ConfigError(f"{root} exists and is not a directory: name a new directory for the keys")
    existed = root.exists()
    try:
        with _writing(root):
            root.mkdir(parents=True, exist_ok=True)
            ca_key, ca_cert = _new_ca(days)
            (root / _CA_DIR).mkdir(mode=0o700)
            _write(root / _CA_DIR / "ca.key", _pem_key(ca_key), secret=True)
            _write(root / _CA_DIR / "ca.pem", _pem_cert(ca_cert))
        return add(root, names, addresses, days)
    except ConfigError:  # nothing half made is left: what this call created goes
        shutil.rmtree(root if not existed else root / _CA_DIR, ignore_errors=True)
        raise


def add(out: str | os.PathLike[str], names: list[str], addresses: dict[str, list[str]] | None = None,
        days: int = _DAYS) -> list[Path]:
    """Machine directories for `names`, signed by `out`'s CA; every machine directory under `out` (old
    and new) gets the new machines' public keys in `peers/` (copy the updated ones out again)."""
    from cryptography import x509
    from cryptography.hazmat.primitives import serialization

    root = Path(os.path.expanduser(os.fspath(out)))
    ca_dir = root / _CA_DIR
    if not (ca_dir / "ca.key").is_file():
        raise ConfigError(f"{root}: no station CA (ca/ca.key): make one with `rio keys generate {root} --name ...`")
    _check_request(names, addresses, days)
    taken = [n for n in names if (root / n).exists()]
    if taken:
        raise ConfigError(f"{root}: {', '.join(taken)} already exist (remove a machine's directory to re-key it)")
    check_private(ca_dir / "ca.key")
    ca_key = serialization.load_pem_private_key((ca_dir / "ca.key").read_bytes(), password=None)
    ca_cert = x509.load_pem_x509_certificate((ca_dir / "ca.pem").read_bytes())
    made: list[Path] = []
    started: list[Path] = []
    try:
        with _writing(root):
            for name in names:
                started.append(root / name)
                made.append(_machine(root, name, ca_key, ca_cert, (addresses or {}).get(name, []), days))
            _share_public_keys(root)
    except ConfigError:  # the machines of this call, half made or not, go
        for d in started:
            shutil.rmtree(d, ignore_errors=True)
        raise
    return made


def machines(out: str | os.PathLike[str]) -> list[str]:
    """The machine directories under a `generate` directory."""
    root = Path(os.path.expanduser(os.fspath(out)))
    return sorted(p.name for p in root.iterdir() if (p / "identity").is_file()) if root.is_dir() else []


def address_problem(host: str) -> str | None:
    """Why `host` cannot be written into a certificate as an address a machine is reached at (None: it
    can): an IP address, or a host name of RFC 1123 labels ('robot-1.lab'); `rio keys generate --address
    'a=not an ip'` wrote a certificate naming "not an ip"."""
    try:
        ipaddress.ip_address(host)
        return None
    except ValueError:
        pass
    if not host or len(host) > 253 or not all(_LABEL.match(label) for label in host.removesuffix(".").split(".")):
        return f"'{host}' is neither an IP address nor a host name (letters, digits, '-' and dots)"
    return None


def _check_request(names: list[str], addresses: dict[str, list[str]] | None, days: int) -> None:
    """Names, addresses and validity of a `generate`/`add`, all checked before anything is written."""
    _check_names(names)
    for name, hosts in (addresses or {}).items():
        for host in hosts:
            if (why := address_problem(host)) is not None:
                raise ConfigError(f"address of machine '{name}': {why}")
    if isinstance(days, bool) or not isinstance(days, int) or not 1 <= days <= MAX_DAYS:
        raise ConfigError(f"validity of {days!r} days: a certificate is valid for 1 to {MAX_DAYS} days")


@contextlib.contextmanager
def _writing(root: Path) -> Iterator[None]:
    """An OSError while writing keys (no permission, a full disk, a path under /proc) as one ConfigError
    naming the directory, not a traceback."""
    try:
        yield
    except OSError as e:
        where = f" ({e.filename})" if e.filename else ""
        raise ConfigError(f"{root}: cannot write the keys here: {e.strerror or e}{where}") from None


def _check_names(names: list[str]) -> None:
    if not names:
        raise ConfigError("name at least one machine (--name robot --name workstation)")
    for n in names:
        if not NAME.match(n) or n == _CA_DIR:
            raise ConfigError(f"machine name '{n}': letters, digits, '-' and '_' only (and not '{_CA_DIR}')")
    if len(set(names)) != len(names):
        raise ConfigError(f"machine names repeat: {', '.join(names)}")


def _machine(root: Path, name: str, ca_key: Any, ca_cert: Any, addresses: list[str], days: int) -> Path:
    import zmq

    d = root / name
    (d / "peers").mkdir(parents=True)
    os.chmod(d, 0o700)
    key = _new_key()
    cert = _sign(name, key.public_key(), ca_key, ca_cert, addresses, days)
    _write(d / "identity", name + "\n")
    shutil.copyfile(root / _CA_DIR / "ca.pem", d / "ca.pem")
    _write(d / "tls.pem", _pem_cert(cert) + _pem_cert(ca_cert))
    _write(d / "tls.key", _pem_key(key), secret=True)
    public, secret = zmq.curve_keypair()
    _write(d / "curve.key_secret", _zmq_cert(name, public, secret), secret=True)
    _write(d / "peers" / f"{name}.key", _zmq_cert(name, public, None))
    return d


def _share_public_keys(root: Path) -> None:
    """Every machine's `peers/` holds every machine's public key."""
    dirs = [root / n for n in machines(root)]
    for src in dirs:
        own = src / "peers" / f"{src.name}.key"
        for dst in dirs:
            target = dst / "peers" / own.name
            if dst != src and not target.exists():
                shutil.copyfile(own, target)


def _zmq_cert(name: str, public: bytes, secret: bytes | None) -> str:
    """zmq's certificate file format (what `zmq.auth.load_certificate` reads)."""
    lines = [f"#   ZeroMQ CURVE {'Secret' if secret else 'Public'} Certificate for RIO machine '{name}'",
             "#   Exchange securely, or use a secure mechanism to verify the contents", "#   of this file "
             "after exchange." if secret is None else "#   Keep this file private: it authenticates this machine.",
             "metadata", "curve", f'    public-key = "{public.decode()}"']
    if secret is not None:
        lines.append(f'    secret-key = "{secret.decode()}"')
    return "\n".join(lines) + "\n"


def _write(path: Path, text: str | bytes, secret: bool = False) -> None:
    data = text.encode() if isinstance(text, str) else text
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600 if secret else 0o644)
    with os.fdopen(fd, "wb") as f:
        f.write(data)


def _new_key() -> Any:
    from cryptography.hazmat.primitives.asymmetric import ec

    return ec.generate_private_key(ec.SECP256R1())


def _pem_key(key: Any) -> bytes:
    from cryptography.hazmat.primitives import serialization

    return key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                             serialization.NoEncryption())


def _pem_cert(cert: Any) -> bytes:
    from cryptography.hazmat.primitives import serialization

    return cert.public_bytes(serialization.Encoding.PEM)


def _new_ca(days: int) -> tuple[Any, Any]:
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes
    from cryptography.x509.oid import NameOID

    key = _new_key()
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "rio station CA")])
    now = datetime.datetime.now(datetime.timezone.utc)
    cert = (x509.CertificateBuilder().subject_name(subject).issuer_name(subject).public_key(key.public_key())
            .serial_number(x509.random_serial_number()).not_valid_before(now - datetime.timedelta(minutes=5))
            .not_valid_after(now + datetime.timedelta(days=days))
            .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
            .add_extension(x509.KeyUsage(digital_signature=True, key_cert_sign=True, crl_sign=True,
                                         content_commitment=False, key_encipherment=False, data_encipherment=False,
                                         key_agreement=False, encipher_only=False, decipher_only=False),
                           critical=True)
            .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()), critical=False)
            .sign(key, hashes.SHA256()))
    return key, cert


def _sign(name: str, public_key: Any, ca_key: Any, ca_cert: Any, addresses: list[str], days: int) -> Any:
    """A machine certificate: common name = machine name (what zenoh's access control matches), and
    alternative names for the machine name, localhost and any address given (for name checks)."""
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes
    from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

    alt = _alt_names([name, "localhost", "127.0.0.1", *addresses])
    now = datetime.datetime.now(datetime.timezone.utc)
    return (x509.CertificateBuilder()
            .subject_name(x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name)]))
            .issuer_name(ca_cert.subject).public_key(public_key).serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(minutes=5)).not_valid_after(now + datetime.timedelta(days=days))
            .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
            .add_extension(alt, critical=False)
            .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]),
                           critical=False)
            .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(ca_key.public_key()), critical=False)
            .sign(ca_key, hashes.SHA256()))


def _alt_names(names: list[str]) -> Any:
    """Subject alternative names: IP addresses as such, anything else as a DNS name (duplicates once)."""
    from cryptography import x509

    alt: list[x509.GeneralName] = []
    for n in dict.fromkeys(names):
        try:
            alt.append(x509.IPAddress(ipaddress.ip_address(n)))
        except ValueError:
            alt.append(x509.DNSName(n))
    return x509.SubjectAlternativeName(alt)


def self_signed(common_name: str, names: list[str], days: int,
                now: datetime.datetime | None = None) -> tuple[bytes, bytes]:
    """(private key PEM, certificate PEM): a self-signed server certificate for `names` (host names or IP
    addresses), for a page served from this machine that a browser is asked to trust once (the WebXR
    teleop page). Stations' links use the station CA instead (`generate`)."""
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes
    from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

    key = _new_key()
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, common_name),
                         x509.NameAttribute(NameOID.ORGANIZATION_NAME, "rio (self-signed)")])
    now = now or datetime.datetime.now(datetime.timezone.utc)
    cert = (x509.CertificateBuilder().subject_name(subject).issuer_name(subject).public_key(key.public_key())
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(minutes=5)).not_valid_after(now + datetime.timedelta(days=days))
            .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
            .add_extension(_alt_names(names), critical=False)
            .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH]), critical=False)
            .sign(key, hashes.SHA256()))
    return _pem_key(key), _pem_cert(cert)
