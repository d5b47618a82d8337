"""`ati.netft` against the emulated box: SI units from the page's calibration whatever units the box is
configured in, the box's own bias through tare(), lost datagrams counted from rdt_sequence gaps, a
silent box asked to stream again, start-up failures naming the node; and the wrench conformance kit."""

from __future__ import annotations

import socket
import time
from contextlib import contextmanager

import numpy as np
import pytest
from rio_ati import rdt
from rio_ati.driver import NetFTSensor
from rio_ati.emulator import NetFTBox

from rio.conformance.drivers import WrenchConformance
from rio.errors import RioError
from rio.testing import lifecycle, wait_until

LOAD = [2.0, -1.0, -9.81, 0.2, -0.1, 0.05]


def fields(box: NetFTBox, **extra) -> dict:
    return {"ip": box.host, "rdt_port": box.rdt_port, "http_port": box.http_port, **extra}


def next_sample(node: NetFTSensor, timeout: float = 5.0) -> dict:
    got: dict = {}

    def read() -> bool:
        s = node.read_state()
        if s is not None:
            got.update(s)
        return s is not None

    assert wait_until(read, timeout=timeout, period=0.002), "no sample"
    return got


def test_publishes_si_units_from_a_box_in_lbf_and_lbf_in():
    with NetFTBox(LOAD, counts_per_force=1000.0, counts_per_torque=1000.0, force_unit="lbf",
                  torque_unit="lbf-in") as box:
        with lifecycle(NetFTSensor(**fields(box))) as ft:
            s = next_sample(ft)
        # close() stops the stream: wait for the box (still serving) to have taken the datagram
        assert wait_until(lambda: [c for c, _ in box.requests][-1:] == [rdt.STOP], timeout=5.0), box.requests
    assert s["force"] == pytest.approx(LOAD[:3], abs=0.005) and s["torque"] == pytest.approx(LOAD[3:], abs=1e-3)
    assert s["status"] == 0 and s["rdt_sequence"] >= 1 and s["lost"] == 0
    asked = [c for c, _ in box.requests]  # start (again, if the first record was slow to come), then stop
    assert set(asked[:-1]) == {rdt.START_REALTIME} and asked[-1] == rdt.STOP


def test_tare_biases_the_box_itself():
    with NetFTBox(LOAD) as box, lifecycle(NetFTSensor(**fields(box))) as ft:
        next_sample(ft)
        time.sleep(0.05)  # records queue up in the socket, measured before the bias
        assert ft.tare() == [0.0] * 6  # the kind keeps no bias: the box's is the zero
        after = [next_sample(ft) for _ in range(30)]
        assert max(np.abs(s["force"]).max() for s in after) < 1e-5  # not one of those published
        asked = [c for c, _ in box.requests]
        assert asked[asked.index(rdt.SET_SOFTWARE_BIAS) + 1] == rdt.START_REALTIME  # a fresh stream after the bias
        box.load = np.array(LOAD) + [0.0, 0.0, -4.9, 0.0, 0.0, 0.0]
        assert wait_until(lambda: next_sample(ft)["force"][2] == pytest.approx(-4.9, abs=1e-5), timeout=5.0)


def test_the_kinds_software_tare_where_asked():
    with NetFTBox(LOAD) as box, lifecycle(NetFTSensor(**fields(box, device_tare=False, tare_samples=3))) as ft:
        for _ in range(3):
            next_sample(ft)
        assert ft.tare() == pytest.approx(LOAD, abs=1e-5)
        assert np.abs(next_sample(ft)["force"]).max() < 1e-5
    assert rdt.SET_SOFTWARE_BIAS not in [c for c, _ in box.requests]


def test_lost_datagrams_are_counted_from_sequence_gaps():
    with NetFTBox(LOAD, rate_hz=1000.0) as box, lifecycle(NetFTSensor(**fields(box))) as ft:
        next_sample(ft)
        box.drop_every = 4
        assert wait_until(lambda: next_sample(ft)["lost"] >= 20, timeout=10.0)
        box.drop_every = 0
        # each gap is seen once the record after it arrives: then the count is exactly what the box dropped
        assert wait_until(lambda: next_sample(ft)["lost"] == box.dropped, timeout=10.0), (ft.lost, box.dropped)
    assert box.dropped >= 20 and ft.received > 3 * box.dropped * 0.5


def test_a_silent_box_is_asked_to_stream_again():
    with NetFTBox(LOAD) as box, lifecycle(NetFTSensor(**fields(box, restart_s=0.2))) as ft:
        next_sample(ft)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as other:  # someone stops the box's stream
            other.sendto(rdt.request(rdt.STOP), (box.host, box.rdt_port))
        assert wait_until(lambda: not box.streaming, timeout=2.0)
        time.sleep(0.1)
        while ft.read_state() is not None:  # what was in flight
            pass
        t_silent = time.monotonic()
        s = next_sample(ft, timeout=5.0)  # the driver restarts it after restart_s
    assert time.monotonic() - t_silent >= 0.1
    assert [c for c, _ in box.requests].count(rdt.START_REALTIME) >= 2 and s["force"][2] == pytest.approx(-9.81)


def test_startup_failures_name_the_node_and_what_to_do():
    with NetFTBox(LOAD) as box:
        node = NetFTSensor(**fields(box, http_port=1, connect_timeout_s=0.5))
        node.name = "ft"
        with pytest.raises(RioError, match="node 'ft': cannot read the calibration.*counts_per_force"):
            node.open()
        node = NetFTSensor(**fields(box, rdt_port=9, counts_per_force=1e6, counts_per_torque=1e6,
                                    connect_timeout_s=0.3))
        node.name = "ft"
        with pytest.raises(RioError, match="node 'ft': no RDT record .* within 0.3 s"):
            node.open()
        node.close()


class TestNetFTConformance(WrenchConformance):
    driver = "ati.netft"
    bad_config = {"http_port": 1, "connect_timeout_s": 0.3}
    tare_tol_n = tare_tol_nm = 0.05  # the box biases with one reading: its noise (0.01) stays in the zero

    @contextmanager
    def emulator(self):
        with NetFTBox(LOAD, noise=0.01) as box:
            yield fields(box)
