"""`rio_unitree.testing.free_domain_id`: a test process asking for more domains than its range holds gets the
ones it handed out longest ago again (each still probed), instead of running out: a pytest-xdist worker draws
from half of the range and asks once per G1 test, and ran out in the middle of the suite. And the range itself:
Cyclone's ports for it lie below the kernel's ephemeral ports, and a port another socket holds is named."""

from __future__ import annotations

import socket

import pytest
from rio_unitree import testing
from rio_unitree.dds import Participant, udp_ports

from rio.machine.parallel import worker_share

#: Outside the 2..100 the other tests draw from (`testing.TEST_DOMAINS`), so their robots are never on these.
LO, HI = 220, 223


def test_domains_are_handed_out_again_the_longest_ago_first(monkeypatch):
    monkeypatch.setattr(testing, "_handed_out", type(testing._handed_out)())  # as in a fresh process
    share = list(worker_share(LO, HI))
    got = [testing.free_domain_id(lo=LO, hi=HI, listen_s=0.05) for _ in range(2 * len(share) + 1)]
    first = got[:len(share)]
    assert sorted(first) == share  # every domain of the share once before any again
    assert got[len(share):] == first + first[:1]  # then again, in the order they were first handed out


def test_test_domains_keep_cyclones_ports_below_the_ephemeral_range():
    """Cyclone binds 7400 + 250 * domain + 0..249: a test domain whose ports the kernel may hand to any socket
    fails at random on a busy machine (domain 139 did, in a parallel run)."""
    lo, hi = testing.TEST_DOMAINS
    with open("/proc/sys/net/ipv4/ip_local_port_range") as f:
        first_ephemeral = int(f.read().split()[0])
    assert lo >= 2 and udp_ports(hi)[-1] < first_ephemeral


def test_a_port_taken_by_another_socket_is_named_in_the_error():
    domain = 230  # outside every range the tests draw from
    port = udp_ports(domain)[0]
    holder = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)  # no SO_REUSEADDR: Cyclone cannot share it
    try:
        holder.bind(("0.0.0.0", port))
        with pytest.raises(ValueError) as e:
            Participant(domain, "lo").close()
        assert f"domain {domain}" in str(e.value) and f"UDP ports {port}-{port + 249}" in str(e.value)
    finally:
        holder.close()
