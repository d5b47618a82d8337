"""The register models on their own (`handle(frame)`, frames without CRC, a hand-moved clock): the
Robotiq manual's example exchanges byte for byte, Modbus exceptions, and the DH register map. This is
the API other plugins' emulators call (a Robotiq on an arm's tool RS-485)."""

from __future__ import annotations

import pytest
from rio_robotiq.emulator.registers import DhRegisters, RobotiqRegisters


class Clock:
    def __init__(self):
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def h(text: str) -> bytes:
    return bytes.fromhex(text)


@pytest.fixture
def clock():
    return Clock()


@pytest.fixture
def robotiq(clock):
    return RobotiqRegisters("2f85", clock=clock, activation_s=0.5)


def activate(regs, clock):
    assert regs.handle(h("09 10 03 E8 00 03 06 01 00 00 00 00 00")) == h("09 10 03 E8 00 03")
    clock.t += 1.0


def test_the_manuals_activation_exchange(robotiq, clock):
    # clear rACT, then set it (the manual's step 1); status reads "activating", then "activation completed"
    assert robotiq.handle(h("09 10 03 E8 00 03 06 00 00 00 00 00 00")) == h("09 10 03 E8 00 03")
    assert robotiq.handle(h("09 03 07 D0 00 01")) == h("09 03 02 00 00")
    assert robotiq.handle(h("09 10 03 E8 00 03 06 01 00 00 00 00 00")) == h("09 10 03 E8 00 03")
    assert robotiq.handle(h("09 03 07 D0 00 01")) == h("09 03 02 11 00")
    clock.t += 0.6
    assert robotiq.handle(h("09 03 07 D0 00 01")) == h("09 03 02 31 00")
    assert robotiq.activated


def test_the_manuals_grasp_exchange(robotiq, clock):
    activate(robotiq, clock)
    robotiq.fingers.object_width = (1 - 189 / 255) * 0.085  # where the manual's example stops: 189/255
    assert robotiq.handle(h("09 10 03 E8 00 03 06 09 00 00 FF FF FF")) == h("09 10 03 E8 00 03")
    reply = robotiq.handle(h("09 04 07 D0 00 03"))
    assert reply[:3] == h("09 04 06") and reply[3] >> 6 == 0  # gOBJ 0: moving
    clock.t += 2.0
    reply = robotiq.handle(h("09 04 07 D0 00 03"))
    assert reply[:8] == h("09 04 06 B9 00 00 FF BD")  # gOBJ 2 (contact while closing), echo FF, position 189
    assert reply[8] > 0  # current while squeezing
    assert robotiq.force == pytest.approx(235.0) and robotiq.speed == pytest.approx(0.150)


def test_opening_completes_at_the_requested_position(robotiq, clock):
    activate(robotiq, clock)
    robotiq.handle(h("09 10 03 E8 00 03 06 09 00 00 FF FF FF"))
    clock.t += 2.0
    robotiq.handle(h("09 10 03 E8 00 03 06 09 00 00 00 FF FF"))
    clock.t += 2.0
    assert robotiq.handle(h("09 04 07 D0 00 03")) == h("09 04 06 F9 00 00 00 00 00")  # gOBJ 3, open, no current
    assert robotiq.position == pytest.approx(0.085)


def test_function_3_and_4_read_both_blocks_and_6_writes(robotiq, clock):
    activate(robotiq, clock)
    assert robotiq.handle(h("09 06 03 E9 00 80")) == h("09 06 03 E9 00 80")  # FC06 echo
    assert robotiq.handle(h("09 03 03 E8 00 03")) == h("09 03 06 01 00 00 80 00 00")
    assert robotiq.handle(h("09 04 07 D0 00 08"))[:3] == h("09 04 10")  # the whole 16-byte block


@pytest.mark.parametrize("request_hex, reply_hex", [
    ("09 03 00 00 00 01", "09 83 02"),                    # no register there
    ("09 04 07 D6 00 03", "09 84 02"),                    # runs past the input block
    ("09 10 07 D0 00 01 02 00 00", "09 90 02"),           # the status block is read-only
    ("09 10 03 E8 00 02 06 00 00 00 00 00 00", "09 90 03"),  # 2 registers but 6 bytes
    ("09 2B 0E 01 00", "09 AB 01"),                       # a function it does not have
    ("09 03 03 E8 00 00", "09 83 03"),                    # zero registers
])
def test_exceptions(robotiq, request_hex, reply_hex):
    assert robotiq.handle(h(request_hex)) == h(reply_hex)


def test_other_slaves_and_broadcast(robotiq):
    assert robotiq.handle(h("01 03 07 D0 00 01")) == b""  # another slave's request: silence
    assert robotiq.handle(h("00 10 03 E8 00 03 06 01 00 00 00 00 00")) == b""  # broadcast: applied, no reply
    assert robotiq.rACT == 1


def test_priority_faults_and_a_major_fault(robotiq, clock):
    robotiq.handle(h("09 10 03 E8 00 03 06 08 00 00 FF FF FF"))  # rGTO without rACT
    assert robotiq.status()["gFLT"] == 0x07
    activate(robotiq, clock)
    assert robotiq.status()["gFLT"] == 0
    robotiq.handle(h("09 10 03 E8 00 03 06 09 00 00 FF FF FF"))
    clock.t += 0.1
    robotiq.inject_fault(0x0E)
    stopped_at = robotiq.position
    clock.t += 1.0
    assert robotiq.position == pytest.approx(stopped_at)  # a major fault stops the fingers
    assert robotiq.handle(h("09 04 07 D0 00 02"))[5] == 0x0E
    robotiq.handle(h("09 10 03 E8 00 03 06 09 00 00 00 FF FF"))  # motion refused until a reset
    clock.t += 1.0
    assert robotiq.position == pytest.approx(stopped_at)
    robotiq.set_request(rACT=0)
    robotiq.set_request(rACT=1)
    clock.t += 1.0
    assert robotiq.status()["gFLT"] == 0 and robotiq.activated


def test_set_request_is_a_register_write(robotiq):
    robotiq.set_request(rACT=1, rPR=200, rSP=10, rFR=20)
    assert robotiq.output[:3] == [0x0100, 200, 10 << 8 | 20]
    with pytest.raises(ValueError, match="unknown request fields"):
        robotiq.set_request(POS=3)


# -- DH ----------------------------------------------------------------------------------------------------
def test_dh_initialization_position_and_states(clock):
    dh = DhRegisters("ag95", clock=clock)
    assert dh.handle(h("01 03 02 00 00 03")) == h("01 03 06 00 00 00 01 03 E8")  # not initialized, open
    assert dh.handle(h("01 06 01 00 00 01")) == h("01 06 01 00 00 01")
    assert dh.handle(h("01 03 02 00 00 01")) == h("01 03 02 00 01")  # the fingers are already open
    dh.handle(h("01 06 01 03 01 F4"))  # 500 per mille
    assert dh.handle(h("01 03 02 01 00 01")) == h("01 03 02 00 00")  # moving
    clock.t += 5.0
    assert dh.handle(h("01 03 02 00 00 03")) == h("01 03 06 00 01 00 01 01 F4")
    dh.fingers.object_width = 0.02
    dh.handle(h("01 06 01 03 00 00"))
    clock.t += 5.0
    assert dh.handle(h("01 04 02 01 00 02")) == h("01 04 04 00 02 00 D3")  # caught at 20 mm = 211 per mille
    dh.fingers.object_width = None
    clock.t += 5.0
    assert dh.handle(h("01 03 02 01 00 01")) == h("01 03 02 00 03")  # dropped


@pytest.mark.parametrize("request_hex, reply_hex", [
    ("01 06 01 01 00 0A", "01 86 03"),  # force 10 %: below 20
    ("01 06 01 03 03 E9", "01 86 03"),  # position 1001
    ("01 06 01 00 00 02", "01 86 03"),  # initialization takes 1 or 0xA5
    ("01 06 02 01 00 00", "01 86 02"),  # feedback is read-only
    ("01 03 01 05 00 01", "01 83 02"),  # nothing at 0x0105
])
def test_dh_exceptions(clock, request_hex, reply_hex):
    assert DhRegisters("ag95", clock=clock).handle(h(request_hex)) == h(reply_hex)


def test_dh_power_cycle_loses_the_initialization(clock):
    dh = DhRegisters("ag105", clock=clock)
    dh.handle(h("01 06 01 00 00 01"))
    clock.t += 1.0
    assert dh.init_state == 1
    dh.power_cycle()
    assert dh.handle(h("01 03 02 00 00 01")) == h("01 03 02 00 00")
    dh.handle(h("01 06 01 03 00 00"))  # ignored until initialized again
    clock.t += 1.0
    assert dh.position == pytest.approx(0.145)
