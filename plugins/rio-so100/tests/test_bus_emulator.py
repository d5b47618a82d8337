"""The emulated bus through the real SDK code path (`scservo_sdk` on a pty), and `FeetechBus` on top:
positions, sync reads, corrupted packets, silent servos, EEPROM lock, a port shared by two users."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
from rio_so100.calibration import default_calibration
from rio_so100.errors import BusError, ServoFault
from rio_so100.feetech import control_table as T
from rio_so100.feetech import protocol as P
from rio_so100.feetech.bus import FeetechBus
from rio_so100.models import ARM_JOINTS
from rio_so100.servo_group import ServoGroup


def _group(port: str, names=ARM_JOINTS) -> ServoGroup:
    cal = default_calibration("so100", "follower")
    joints = {n: cal.joint(n) for n in names}
    bus = FeetechBus(port, names={j.id: n for n, j in joints.items()}).open()
    return ServoGroup(bus, joints)


def test_ping_reports_the_sts3215_model_and_silence_names_the_id(vbus):
    with FeetechBus(vbus.port, names={9: "nobody"}) as bus:
        assert bus.ping(1) == T.STS3215_MODEL
        with pytest.raises(BusError, match=r"servo 9 \(nobody\): no answer \(timeout\) after 3 tries"):
            bus.ping(9)


def test_position_round_trip_in_radians(vbus):
    g = _group(vbus.port)
    try:
        g.set_torque(True)
        q = np.array([0.4, -0.3, 0.8, -0.5, 1.2])
        g.write_rad(q)
        deadline = time.monotonic() + 2.0
        while time.monotonic() < deadline:
            s = g.read()
            if np.allclose(s["joint_pos"], q, atol=2 * 2 * np.pi / 4096):
                break
            time.sleep(0.01)
        assert np.allclose(s["joint_pos"], q, atol=2 * 2 * np.pi / 4096), s["joint_pos"]
        # what went over the wire: goal registers in steps around mid-turn, present positions likewise
        assert [vbus.servo(i).reg(T.GOAL_POSITION) for i in range(1, 6)] == \
            [2048 + round(x * 4096 / (2 * np.pi)) for x in q]
        assert np.all(s["error"] == 0) and np.allclose(s["voltage"], 7.4)
    finally:
        g.bus.close()


def test_sync_read_of_six_servos_is_fast(vbus):
    g = _group(vbus.port, [*ARM_JOINTS, "gripper"])
    try:
        n, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < 0.5:
            g.read()
            n += 1
        rate = n / (time.perf_counter() - t0)
        print(f"sync read of 6 servos over the emulated bus: {rate:.0f} Hz")
        assert rate > 200  # far above the 100 Hz driver loop, even on 2 shared cores
        assert vbus.stats["inst_0x82"] >= n
    finally:
        g.bus.close()


def test_corrupted_checksum_is_retried_then_reported(vbus):
    with FeetechBus(vbus.port, retries=2, names={3: "elbow_flex"}) as bus:
        vbus.corrupt_replies(1, servo_id=3)
        data, errors = bus.sync_read(range(1, 7), *T.STATE_BLOCK)  # one bad packet: retried, fine
        assert bus.retried == 1 and sorted(data) == [1, 2, 3, 4, 5, 6] and vbus.stats["corrupted"] == 1
        vbus.corrupt_replies(3, servo_id=3)  # as many as there are tries
        with pytest.raises(BusError, match=r"servo 3 \(elbow_flex\): corrupt status packet \(checksum\) after 3 tries"):
            bus.sync_read(range(1, 7), *T.STATE_BLOCK)
        assert bus.read(3, T.PRESENT_POSITION) == 2048  # and the bus is usable afterwards


def test_unresponsive_servo_raises_naming_its_id(vbus):
    vbus.servo(4).responsive = False
    with FeetechBus(vbus.port, retries=1, names={4: "wrist_flex"}) as bus:
        with pytest.raises(BusError, match=r"servo 4 \(wrist_flex\): no answer \(timeout\) after 2 tries; check"):
            bus.sync_read(range(1, 7), *T.STATE_BLOCK)


def test_status_error_bits_reach_the_caller(vbus):
    vbus.servo(2).temperature = 75.0  # above MAX_TEMPERATURE (70)
    with FeetechBus(vbus.port, names={2: "shoulder_lift"}) as bus:
        _, errors = bus.sync_read(range(1, 7), *T.STATE_BLOCK)
        assert errors == {1: 0, 2: P.ERR_OVERHEAT, 3: 0, 4: 0, 5: 0, 6: 0}
        with pytest.raises(ServoFault, match=r"servo 2 \(shoulder_lift\): overheat"):
            bus.write(2, T.TORQUE_ENABLE, 1)


def test_eeprom_needs_unlock_and_homing_offset_shifts_the_reading(vbus):
    with FeetechBus(vbus.port) as bus:
        bus.write(1, T.HOMING_OFFSET, -300)  # locked: ignored, as on the servo
        assert bus.read(1, T.HOMING_OFFSET) == 0
        bus.write(1, T.LOCK, 0)
        bus.write(1, T.HOMING_OFFSET, -300)
        bus.write(1, T.LOCK, 1)
        assert bus.read(1, T.HOMING_OFFSET) == -300  # sign-magnitude round trip
        assert bus.read(1, T.PRESENT_POSITION) == 2048 + 300  # present = encoder - offset


def test_bad_instruction_checksum_is_ignored_by_the_servo(vbus):
    import os

    import serial

    with serial.Serial(vbus.port, timeout=0.05) as s:
        good = P.packet(1, P.PING)
        s.write(good[:-1] + bytes([good[-1] ^ 0xFF]))
        assert s.read(6) == b""
        s.write(good)
        assert s.read(6) == P.packet(1, 0)
    assert vbus.stats["bad_checksum"] == 1
    assert os.path.exists(vbus.port)


def test_two_users_share_one_port(vbus):
    """An arm node and a gripper node open the same bus: the port lock keeps their packets apart."""
    errors = []

    def user(ids):
        try:
            with FeetechBus(vbus.port) as bus:
                for _ in range(150):
                    data, _ = bus.sync_read(ids, *T.STATE_BLOCK)
                    assert sorted(data) == sorted(ids)
                    bus.sync_write(T.GOAL_POSITION, {i: 2048 for i in ids})
        except Exception as e:  # pragma: no cover - reported below
            errors.append(e)

    threads = [threading.Thread(target=user, args=(ids,)) for ids in ([1, 2, 3, 4, 5], [6])]
    for t in threads:
        t.start()
    for t in threads:
        t.join(30)
    assert not errors, errors
