"""`rio keys` and the `keys` field of network middlewares: the files a multi-machine station's
authentication rests on, and what a station that reaches beyond loopback must say."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from rio.errors import ConfigError
from rio.machine import keys
from rio.middleware.protocol import NetworkConfig


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    root = tmp_path_factory.mktemp("keys") / "lab"
    keys.generate(root, ["robot", "workstation"], {"robot": ["10.0.0.2", "robot.local"]}, days=30)
    return root


def test_generate_makes_one_private_directory_per_machine_trusting_every_machine(lab):
    assert keys.machines(lab) == ["robot", "workstation"]
    for name in ("robot", "workstation"):
        k = keys.load(lab / name)
        assert k.identity == name
        assert sorted(k.peers) == ["robot", "workstation"]
        public, secret = k.curve_keypair()
        assert len(public) == 40 and len(secret) == 40 and public == k.peers[name]
        for f in (k.tls_key, k.curve_secret):
            assert os.stat(f).st_mode & 0o077 == 0, f
    # the CA's private key is not in any machine's directory
    assert not any(p.name == "ca.key" for p in (lab / "robot").rglob("*"))
    assert (lab / "ca" / "ca.key").is_file()


def test_machine_certificates_chain_to_the_station_ca_with_the_machine_as_common_name(lab):
    from cryptography import x509
    from cryptography.x509.oid import NameOID

    ca = x509.load_pem_x509_certificate((lab / "robot" / "ca.pem").read_bytes())
    cert = x509.load_pem_x509_certificates((lab / "robot" / "tls.pem").read_bytes())[0]
    assert cert.subject.get_attributes_for_oid(NameOID.COMMON_NAME)[0].value == "robot"
    cert.verify_directly_issued_by(ca)  # raises if not signed by the CA
    alt = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert "robot.local" in alt.get_values_for_type(x509.DNSName)
    assert "10.0.0.2" in {str(a) for a in alt.get_values_for_type(x509.IPAddress)}
    other = x509.load_pem_x509_certificates((lab / "workstation" / "tls.pem").read_bytes())[0]
    other.verify_directly_issued_by(ca)


def test_add_signs_with_the_same_ca_and_teaches_every_machine_the_new_key(tmp_path):
    keys.generate(tmp_path / "s", ["a"])
    keys.add(tmp_path / "s", ["b"])
    assert sorted(keys.load(tmp_path / "s" / "a").peers) == ["a", "b"]
    assert sorted(keys.load(tmp_path / "s" / "b").peers) == ["a", "b"]
    with pytest.raises(ConfigError, match="already exist"):
        keys.add(tmp_path / "s", ["a"])
    with pytest.raises(ConfigError, match="already holds a station CA"):
        keys.generate(tmp_path / "s", ["c"])


@pytest.mark.parametrize("names", [[], ["a/b"], ["ca"], ["x", "x"], ["../up"]])
def test_bad_machine_names_are_refused_before_anything_is_written(tmp_path, names):
    with pytest.raises(ConfigError):
        keys.generate(tmp_path / "k", names)
    assert not (tmp_path / "k").exists()


@pytest.mark.parametrize(("addresses", "days", "said"), [
    ({"robot": ["not an ip"]}, 30, "'not an ip' is neither an IP address nor a host name"),
    ({"robot": ["-robot.lab"]}, 30, "'-robot.lab' is neither"),
    ({"robot": ["a" * 64 + ".lab"]}, 30, "is neither"),
    ({}, 0, "valid for 1 to 36500 days"),
    ({}, 99999999, "valid for 1 to 36500 days"),  # was an OverflowError traceback after the directory was made
])
def test_addresses_and_validity_are_checked_before_anything_is_written(tmp_path, addresses, days, said):
    with pytest.raises(ConfigError, match=said):
        keys.generate(tmp_path / "lab", ["robot"], addresses, days=days)
    assert not (tmp_path / "lab").exists()


def test_keys_where_nothing_can_be_written_are_one_error_and_leave_nothing(tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(ConfigError, match="exists and is not a directory"):
        keys.generate(tmp_path / "file", ["robot"])
    with pytest.raises(ConfigError, match=r"file/lab: cannot write the keys here: Not a directory"):
        keys.generate(tmp_path / "file" / "lab", ["robot"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_load_names_what_is_wrong(lab, tmp_path):
    with pytest.raises(ConfigError, match="does not exist"):
        keys.load(tmp_path / "nowhere")
    with pytest.raises(ConfigError, match="name one machine's directory"):
        keys.load(lab)
    import shutil

    copy = tmp_path / "robot"
    shutil.copytree(lab / "robot", copy)
    os.chmod(copy / "tls.key", 0o644)
    with pytest.raises(ConfigError, match="readable by other users"):
        keys.load(copy)
    os.chmod(copy / "tls.key", 0o600)
    (copy / "curve.key_secret").unlink()
    with pytest.raises(ConfigError, match="missing curve.key_secret"):
        keys.load(copy)
    k = keys.load(lab / "robot")
    with pytest.raises(ConfigError, match="not one this machine trusts"):
        k.peer("stranger")


def test_a_network_node_beyond_loopback_needs_keys_or_insecure(lab):
    with pytest.raises(ValueError, match="rio keys generate"):
        NetworkConfig(host="0.0.0.0")
    assert NetworkConfig(host="0.0.0.0", keys=str(lab / "robot")).machine_keys().identity == "robot"
    assert NetworkConfig(host="0.0.0.0", insecure=True).machine_keys() is None
    with pytest.raises(ValueError, match="does not exist"):
        NetworkConfig(keys=str(lab / "nobody"))


def test_portal_refuses_keys_it_cannot_use(lab):
    from rio.middleware.portal import PortalMiddleware

    with pytest.raises(ValueError, match="no authentication"):
        PortalMiddleware.Config(keys=str(lab / "robot"))


def test_the_command_line_makes_keys_and_refuses_to_overwrite_them(tmp_path):
    def rio(*args):
        return subprocess.run([sys.executable, "-m", "rio", "keys", *args], capture_output=True, text=True)

    r = rio("generate", str(tmp_path / "k"), "--name", "robot", "--name", "ws", "--address", "robot=10.1.2.3")
    assert r.returncode == 0, r.stderr
    assert "copy to machine 'robot'" in r.stdout
    r = rio("show", str(tmp_path / "k" / "ws"))
    assert r.returncode == 0 and "trusts:   robot, ws" in r.stdout
    r = rio("generate", str(tmp_path / "k"), "--name", "x")
    assert r.returncode == 1 and r.stderr.startswith("error: ") and "already holds" in r.stderr
    r = rio("generate", str(tmp_path / "j"), "--name", "a", "--address", "b=1.2.3.4")
    assert r.returncode == 2 and "--address" in r.stderr and not (tmp_path / "j").exists()
