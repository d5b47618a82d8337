"""The emulated Net F/T box at its real boundary: a UDP socket sending RDT requests and reading the
records back, and its configuration page over HTTP. What a driver relies on: streaming starts and stops
on command, a sample count is honoured, rdt_sequence counts records one by one, counts convert with the
page's counts-per-unit in the page's units, and the software bias zeroes the present load."""

from __future__ import annotations

import socket
import time
import urllib.request

import numpy as np
import pytest
from rio_ati import calibration, rdt
from rio_ati.emulator import NetFTBox

LOAD = [1.5, -2.0, -9.81, 0.12, -0.05, 0.3]


@pytest.fixture
def box():
    with NetFTBox(LOAD, rate_hz=500.0) as b:
        yield b


@pytest.fixture
def udp(box):
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.connect((box.host, box.rdt_port))
    s.settimeout(2.0)
    yield s
    s.close()


def records(sock: socket.socket, n: int) -> list[rdt.Record]:
    out: list[rdt.Record] = []
    while len(out) < n:
        out += rdt.parse_records(sock.recv(65536))
    return out


def quiet(sock: socket.socket, seconds: float = 0.3) -> list[bytes]:
    """Datagrams that still arrive within `seconds` (none, once the box has stopped)."""
    sock.settimeout(seconds)
    got = []
    try:
        while True:
            got.append(sock.recv(65536))
    except TimeoutError:
        return got
    finally:
        sock.settimeout(2.0)


def test_the_protocol_bytes():
    assert rdt.request(rdt.START_REALTIME, 0) == bytes.fromhex("1234000200000000")
    assert rdt.parse_request(bytes.fromhex("1234004200000005")) == (rdt.SET_SOFTWARE_BIAS, 5)
    with pytest.raises(ValueError, match="header 0x4321"):
        rdt.parse_request(bytes.fromhex("4321000200000000"))
    rec = rdt.record(7, 700, 0, [1, -2, 3, -4, 5, -6])
    assert len(rec) == 36 and rdt.parse_records(rec) == [rdt.Record(7, 700, 0, (1, -2, 3, -4, 5, -6))]
    with pytest.raises(ValueError, match="36-byte"):
        rdt.parse_records(rec[:-1])
    assert rdt.sequence_gap(5, 6) == 0 and rdt.sequence_gap(5, 9) == 3 and rdt.sequence_gap(2**32 - 1, 0) == 0


def test_nothing_streams_until_started_and_stop_stops_it(box, udp):
    assert quiet(udp, 0.2) == []
    udp.send(rdt.request(rdt.START_REALTIME))
    first = records(udp, 50)
    assert all(len(r.counts) == 6 for r in first)
    udp.send(rdt.request(rdt.STOP))
    time.sleep(0.1)  # what was in flight when the box stopped
    quiet(udp, 0.1)
    assert quiet(udp, 0.3) == [] and not box.streaming
    assert [c for c, _ in box.requests] == [rdt.START_REALTIME, rdt.STOP]


def test_a_sample_count_is_honoured_and_sequences_count_records(box, udp):
    udp.send(rdt.request(rdt.START_REALTIME, 25))
    got = records(udp, 25)
    assert quiet(udp, 0.3) == []  # exactly 25, then the box stops by itself
    assert [r.rdt_sequence for r in got] == list(range(1, 26))  # one per record, from 1 at every start
    ft = [r.ft_sequence for r in got]
    assert all(b >= a for a, b in zip(ft, ft[1:], strict=False))  # the box's internal 7 kHz counter never goes back
    assert ft[-1] - ft[0] >= 7000 * 24 / 500 * 0.5  # ~14 internal samples per record at 500 Hz
    udp.send(rdt.request(rdt.START_REALTIME, 3))
    assert [r.rdt_sequence for r in records(udp, 3)] == [1, 2, 3]


def test_buffered_mode_packs_records_per_datagram(box, udp):
    box.buffer_size = 10
    udp.send(rdt.request(rdt.START_BUFFERED, 30))
    datagrams = [udp.recv(65536) for _ in range(3)]
    assert [len(d) for d in datagrams] == [360, 360, 360]
    seqs = [r.rdt_sequence for d in datagrams for r in rdt.parse_records(d)]
    assert seqs == list(range(1, 31))


def test_counts_convert_with_the_served_calibration_in_its_units():
    with NetFTBox(LOAD, counts_per_force=40.0, counts_per_torque=1000.0, force_unit="lbf",
                  torque_unit="lbf-in") as box:
        page = urllib.request.urlopen(f"http://{box.host}:{box.http_port}/{calibration.PAGE}", timeout=5).read()
        cal = calibration.parse(page)
        assert cal.counts_per_n == pytest.approx(40.0 / 4.4482216152605)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.settimeout(2.0)
            s.connect((box.host, box.rdt_port))
            s.send(rdt.request(rdt.START_REALTIME, 1))
            (r,) = records(s, 1)
    force, torque = cal.to_si(r.counts)
    # counts are integers: 40 counts per lbf resolves 0.11 N, 1000 per lbf-in 0.00011 N m
    assert force == pytest.approx(LOAD[:3], abs=0.06) and torque == pytest.approx(LOAD[3:], abs=1e-4)
    assert r.counts[2] == round(-9.81 / 4.4482216152605 * 40)


def test_an_unknown_unit_or_missing_field_is_named():
    with pytest.raises(ValueError, match="force unit 'stone'"):
        calibration.parse("<netft><cfgcpf>1</cfgcpf><cfgcpt>1</cfgcpt><scfgfu>stone</scfgfu></netft>")
    with pytest.raises(ValueError, match="no <cfgcpt>"):
        calibration.parse("<netft><cfgcpf>1</cfgcpf></netft>")


def test_the_software_bias_zeroes_the_present_load(box, udp):
    udp.send(rdt.request(rdt.START_REALTIME, 1))
    before = np.array(records(udp, 1)[0].counts)
    assert np.abs(before).max() > 1e6  # the load, in counts (1e6 per N / N m)
    udp.send(rdt.request(rdt.SET_SOFTWARE_BIAS))
    time.sleep(0.05)
    udp.send(rdt.request(rdt.START_REALTIME, 1))
    assert records(udp, 1)[0].counts == (0, 0, 0, 0, 0, 0)
    box.load = np.array(LOAD) + [0, 0, -1.0, 0, 0, 0]  # 1 N more along -z after the bias
    udp.send(rdt.request(rdt.START_REALTIME, 1))
    assert records(udp, 1)[0].counts == (0, 0, -1_000_000, 0, 0, 0)
