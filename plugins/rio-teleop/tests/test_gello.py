"""GELLO leader arms through the unmodified dynamixel-sdk on the emulated Protocol 2.0 bus: the
emulator against the SDK, calibration, reading at rate, leader-follower on stations, errors."""

from __future__ import annotations

import json
import math
import os
import time

import numpy as np
import pytest
from rio_teleop.gello import control_table as T
from rio_teleop.gello import protocol as P
from rio_teleop.gello.bus import BusError, DynamixelBus
from rio_teleop.gello.calibrate import calibrate_leader
from rio_teleop.gello.calibration import (
    QUARTER,
    CalibrationError,
    GelloCalibration,
    calibrate,
    calibration_path,
    save_calibration,
)
from rio_teleop.gello.driver import GelloLeader
from rio_teleop.gello.emulator import DynamixelBusEmulator, GelloEmulator, emulator_mounting
from rio_teleop.gello.layouts import LAYOUTS, get_layout

from rio.errors import RioError
from rio.station.load import parse_station
from rio.testing import lifecycle
from rio.workflows.teleop import run_teleop

STATIONS = os.path.join(os.path.dirname(__file__), "..", "src", "rio_teleop", "stations")


@pytest.fixture(autouse=True)
def config_home(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    return tmp_path / "config"


@pytest.fixture
def gello():
    made = []

    def make(layout="xarm7", **kw):
        made.append(GelloEmulator(layout, **kw))
        return made[-1]

    yield make
    for g in made:
        g.close()


def _sdk_port(path):
    import dynamixel_sdk as sdk

    ph = sdk.PortHandler(path)
    assert ph.openPort() and ph.setBaudRate(57600)
    return sdk, ph, sdk.PacketHandler(2.0)


# -- the emulator against the unmodified SDK ------------------------------------------------------------
def test_framing_agrees_with_the_sdk():
    """CRC16 and byte stuffing as the SDK computes them (the SDK is the oracle, not the source)."""
    import dynamixel_sdk as sdk

    ph = sdk.PacketHandler(2.0)
    rng = np.random.default_rng(1)
    for _ in range(50):
        params = bytes(rng.integers(0, 256, int(rng.integers(0, 30))).tolist()) + b"\xff\xff\xfd\x01"
        pkt = P.packet(int(rng.integers(0, 253)), P.WRITE, params)
        assert ph.updateCRC(0, list(pkt), len(pkt) - 2) == pkt[-2] | pkt[-1] << 8
        raw = list(P.HEADER + bytes([pkt[4], 0, 0])) + [P.WRITE, *params] + [0, 0]
        n = len(params) + 3
        raw[5], raw[6] = n & 0xFF, n >> 8
        stuffed = ph.addStuffing(raw)
        assert bytes(stuffed[7:7 + len(pkt) - 9]) == pkt[7:-2]
        assert P.unstuff(pkt[7:-2]) == bytes([P.WRITE]) + params


def test_sdk_talks_to_the_emulated_bus():
    """PortHandler / PacketHandler / GroupSyncRead / GroupBulkRead, unmodified, on the pty."""
    with DynamixelBusEmulator([1, 2, 3]) as bus:
        sdk, ph, pk = _sdk_port(bus.port)
        try:
            assert pk.ping(ph, 2)[:2] == (T.XL330_M288, sdk.COMM_SUCCESS)
            assert pk.ping(ph, 9)[1] == sdk.COMM_RX_TIMEOUT  # nobody has id 9
            bus.servo(2).encoder = -5000.0  # multi-turn, negative
            sr = sdk.GroupSyncRead(ph, pk, *T.PRESENT_POSITION)
            for i in (1, 2, 3):
                sr.addParam(i)
            assert sr.txRxPacket() == sdk.COMM_SUCCESS
            assert P.signed(bytes(sr.data_dict[2])) == -5000 and sr.getData(1, *T.PRESENT_POSITION) == 2048
            # torque on locks the EEPROM: the operating mode cannot change (access error, nothing written)
            assert pk.write1ByteTxRx(ph, 3, T.OPERATING_MODE[0], T.CURRENT_POSITION) == (sdk.COMM_SUCCESS, 0)
            assert pk.write1ByteTxRx(ph, 3, T.TORQUE_ENABLE[0], 1) == (sdk.COMM_SUCCESS, 0)
            assert pk.write1ByteTxRx(ph, 3, T.OPERATING_MODE[0], T.POSITION)[1] == P.ERR_ACCESS
            assert pk.read1ByteTxRx(ph, 3, T.OPERATING_MODE[0])[0] == T.CURRENT_POSITION
            # with torque on it goes to its goal
            assert pk.write4ByteTxRx(ph, 3, T.GOAL_POSITION[0], 3000) == (sdk.COMM_SUCCESS, 0)
            time.sleep(0.3)
            assert abs(P.signed(pk.read4ByteTxRx(ph, 3, T.PRESENT_POSITION[0])[0].to_bytes(4, "little")) - 3000) < 30
            br = sdk.GroupBulkRead(ph, pk)
            br.addParam(1, *T.PRESENT_POSITION)
            br.addParam(3, *T.OPERATING_MODE)
            assert br.txRxPacket() == sdk.COMM_SUCCESS and br.getData(3, *T.OPERATING_MODE) == T.CURRENT_POSITION
            # a packet with a bad CRC is ignored, as a servo ignores it
            bad = bytearray(P.packet(1, P.PING))
            bad[-1] ^= 0xFF
            ph.writePort(bytes(bad))
            time.sleep(0.05)
            assert ph.getBytesAvailable() == 0 and bus.stats["bad_crc"] >= 1
        finally:
            ph.closePort()


# -- calibration -----------------------------------------------------------------------------------
def _mounting(layout, rng, *, flip=(), jitter=0.08):
    """A leader as someone assembled it: horns at random multiples of pi/2 (within +-2 turns),
    printed parts a little off, maybe some joints mounted the other way round."""
    lay = get_layout(layout)
    signs = [(-s if k in flip else s) for k, s in enumerate(lay.signs)]
    offsets = (QUARTER * rng.integers(-8, 9, lay.dof) + rng.uniform(-jitter, jitter, lay.dof)).tolist()
    g_open = float(rng.uniform(1.0, 5.0))
    return GelloCalibration(layout, "truth", offsets, signs, g_open, g_open + lay.gripper_travel)


@pytest.mark.parametrize("layout", sorted(LAYOUTS))
def test_calibration_recovers_offsets_from_the_known_pose(gello, layout):
    rng = np.random.default_rng(abs(hash(layout)) % 2 ** 32)
    truth = _mounting(layout, rng)
    g = gello(layout, mounting=truth)  # held in the known pose, trigger released
    cal = calibrate_leader(g.port, layout, name="lab")
    assert np.allclose(cal.offsets, np.round(np.asarray(truth.offsets) / QUARTER) * QUARTER)
    assert cal.signs == list(get_layout(layout).signs)
    assert np.all(np.abs(cal.residual) < 0.1)
    # saved, and read back by the driver: a new pose reads as the follower's angles
    save_calibration(cal)
    q = np.asarray(get_layout(layout).known_pose) + rng.uniform(-0.6, 0.6, get_layout(layout).dof)
    g.pose(q, gripper=0.25)
    with lifecycle(GelloLeader(port=g.port, layout=layout, calibration="lab")) as node:
        s = node.read_state()
    assert np.allclose(s["joint_pos"], q, atol=0.1)  # the printed parts' own error (jitter) is left
    assert s["gripper"] == pytest.approx(0.25, abs=0.01)


def test_signs_from_a_second_pose(gello):
    rng = np.random.default_rng(7)
    truth = _mounting("ur5e", rng, flip=(1, 4), jitter=0.0)
    g = gello("ur5e", mounting=truth)
    second = np.asarray(get_layout("ur5e").known_pose) + np.array([0.5, -0.4, 0.3, 0.6, -0.5, 0.4])

    def wait(step):
        if step == "second pose":
            g.pose(second)

    cal = calibrate_leader(g.port, "ur5e", wait=wait, second_pose=second)
    assert cal.signs == truth.signs and np.allclose(cal.offsets, truth.offsets)


def test_calibration_refuses_a_leader_out_of_the_pose(gello):
    g = gello("fr3")
    q = np.asarray(get_layout("fr3").known_pose)
    q[3] += 0.7  # joint 4 bent 40 degrees away
    g.pose(q)
    with pytest.raises(CalibrationError, match=r"not in the known pose.*joint4 \(\+0\.70 rad\)"):
        calibrate_leader(g.port, "fr3")
    with pytest.raises(CalibrationError, match="7 joints: got 6"):
        calibrate("fr3", np.zeros(6))


def test_calibrate_command_on_an_emulated_leader(config_home):
    from rio_teleop.gello.cli import app
    from typer.testing import CliRunner

    out = CliRunner().invoke(app, ["calibrate", "--port", "emulator", "--layout", "xarm7", "--name", "bench"])
    assert out.exit_code == 0, out.output
    cal = GelloCalibration.from_json(calibration_path("bench", "xarm7").read_text())
    truth = emulator_mounting(get_layout("xarm7"))
    assert np.allclose(cal.offsets, truth.offsets) and cal.signs == truth.signs
    assert cal.gripper_open == pytest.approx(truth.gripper_open, abs=1e-3)
    assert cal.gripper_closed == pytest.approx(truth.gripper_closed, abs=1e-3)  # measured squeezed
    assert "joint4: offset" in out.output
    out = CliRunner().invoke(app, ["read", "--port", "emulator", "--layout", "xarm7", "--calibration", "bench",
                                   "--seconds", "0.5", "--json"])
    assert out.exit_code == 0, out.output
    readings = [json.loads(line) for line in out.stdout.splitlines()]
    assert readings and all(len(r["joint_pos"]) == 7 and 0.0 <= r["gripper"] <= 1.0 for r in readings)


# -- reading ---------------------------------------------------------------------------------------
def test_each_leader_read_is_one_sync_read_of_all_servos(gello, tmp_path):
    """A read costs one Sync Read of all 8 servos through the SDK, never a packet per servo: that is what
    keeps it far faster than the node's rate (the rate itself is `bench/teleop_latency.py --device gello`'s
    raw round trips: a timed assert here would measure the machine's load)."""
    from rio_teleop.gello import protocol as P

    g = gello("xarm7")
    q = np.asarray(g.layout.known_pose) + np.linspace(-0.3, 0.3, g.layout.dof)
    g.pose(q)  # held still: the last read must match it exactly, however late it comes on a loaded machine
    cal_file = tmp_path / "virtual.json"
    save_calibration(g.mounting, cal_file)
    node = GelloLeader(port=g.port, layout="xarm7", calibration=str(cal_file), rate_hz=200)
    node.setup()
    with lifecycle(node):
        before = dict(g.bus.stats)
        reads = 50
        for _ in range(reads):
            s = node.read_state()
        sent = {k: g.bus.stats[k] - before.get(k, 0) for k in g.bus.stats}
    assert sent.get(f"inst_{P.SYNC_READ:#04x}", 0) == reads, sent
    assert sum(n for k, n in sent.items() if k.startswith("inst_")) == reads, sent  # nothing but Sync Reads
    assert sent.get("status", 0) == reads and sent.get("bad_crc", 0) == 0, sent  # one answer burst each
    assert np.allclose(s["joint_pos"], q, atol=0.005)  # the servos' step is 0.0015 rad


# -- leader -> follower ----------------------------------------------------------------------------
def _station(leader_port, cal_file, *, dof=7, layout="xarm7", rate_hz=50):
    return parse_station({
        "name": "gello-lf-test", "rate_hz": rate_hz, "middleware": {"name": "thread"},
        "embodiment": {"action_space": "joint_pos"},
        "components": {
            "arm": {"driver": "rio.fake_arm", "dof": dof, "home": list(get_layout(layout).known_pose)},
            "gripper": {"driver": "rio.fake_gripper"},
            "teleop": {"driver": f"gello.{layout}", "port": leader_port, "calibration": str(cal_file),
                       "rate_hz": 200},
        }}, source="<test>")


def test_follower_tracks_the_leaders_scripted_motion(gello, tmp_path):
    """`rio teleop`'s leader-follower controller on a station: emulated GELLO xArm 7 -> 7-joint fake arm.
    The follower aligns, then tracks the person's motion within a few cycles of lag; the trigger
    drives the gripper across its range."""
    g = gello("xarm7")
    cal_file = save_calibration(g.mounting, tmp_path / "virtual.json")
    q0 = np.asarray(get_layout("xarm7").known_pose)
    start = [math.inf]  # the person starts moving once the follower is aligned
    amp, period = 0.4, 2.0

    def motion(t):
        w = 2 * math.pi * max(t - start[0], 0.0) / period
        return q0 + amp * np.sin(w + np.arange(7)), 0.5 + 0.5 * math.cos(w)

    g.move(motion)
    seen = []

    def on_tick(tick):
        arm = tick.env.robot.clients["arm"].get_state()
        aligned = tick.info["pairs"][0].aligned
        if aligned and start[0] == math.inf:
            start[0] = tick.t + 0.1
        seen.append((tick.t, arm["joint_pos"].copy(), aligned))

    summary = run_teleop(_station(g.port, cal_file), duration=3.0, on_tick=on_tick, log=None)
    pair = summary.details["pairs"][0]
    assert pair["align_s"] is not None and pair["align_s"] < 1.2, summary.format()  # 0.38 rad at 0.5 rad/s
    tracking = [(t, q) for t, q, aligned in seen if aligned and t > start[0] + 0.2]
    assert len(tracking) > 50
    # the arm at time t is where the leader was a little earlier (measured ~55 ms: the leader sample's age,
    # the command's target one 20 ms cycle ahead, the arm's state seen one or two cycles later); the motion
    # reaches 1.26 rad/s, so without the lag the error would be ~0.07 rad. A lag up to 0.3 s is allowed: a
    # loaded machine stalls a thread for that long now and then, and the arm then holds an older pose of the
    # leader's, still on its path (a wrong pose matches no time of it within 0.02 rad on all seven joints)
    lags = np.arange(0.0, 0.3, 0.005)
    lag_err = np.array([[np.max(np.abs(q - motion(t - lag)[0])) for lag in lags] for t, q in tracking]).min(1)
    assert np.percentile(lag_err, 90) < 0.02, np.percentile(lag_err, 90)
    assert pair["final_error"] < 0.15, summary.format()  # ~0.07 rad: 55 ms at up to 1.26 rad/s
    assert summary.late_ticks < summary.ticks // 5


def test_gripper_trigger_maps_to_the_follower_gripper_range(gello, tmp_path):
    g = gello("xarm7")
    cal_file = save_calibration(g.mounting, tmp_path / "virtual.json")
    g.pose(get_layout("xarm7").known_pose, gripper=0.3)
    widths = []
    summary = run_teleop(_station(g.port, cal_file), duration=1.5, log=None,
                         on_tick=lambda tick: widths.append(tick.env.robot.clients["gripper"].get_state()["width"]))
    max_width = 0.085  # rio.fake_gripper's default
    assert widths[-1] == pytest.approx(0.3 * max_width, abs=0.003), summary.format()


def test_packaged_fake_station_runs():
    """`gello-xarm7-fake` as shipped (the leader waves), over the thread middleware."""
    summary = run_teleop(os.path.join(STATIONS, "gello-xarm7-fake.toml"), duration=2.0, middleware="thread",
                         log=None)
    pair = summary.details["pairs"][0]
    assert pair["align_s"] is not None and pair["align_s"] < 1.0, summary.format()
    assert pair["final_error"] < 0.08, summary.format()


def test_bimanual_emulator_station_aligns_both_pairs():
    """ALOHA-style: two GELLOs, two arms (teleop -> arm, teleop2 -> arm2)."""
    summary = run_teleop(os.path.join(STATIONS, "gello-bimanual-fake.toml"), duration=2.0, middleware="thread",
                         log=None)
    assert [a["arm"] for a in summary.details["pairs"]] == ["arm", "arm2"]
    for a in summary.details["pairs"]:
        assert a["align_s"] is not None and a["align_s"] < 1.0, summary.format()
        assert a["final_error"] < 0.08, summary.format()



def test_gello_drives_the_xarm7_through_its_sdk_and_emulator():
    """`gello-xarm7-emulator`: both ends run their real driver code (dynamixel-sdk on the emulated bus,
    the xArm SDK against rio-ufactory's emulator); the arm aligns from its home pose, then follows."""
    pytest.importorskip("rio_ufactory")
    summary = run_teleop(os.path.join(STATIONS, "gello-xarm7-emulator.toml"), duration=5.0, middleware="thread",
                         log=None)
    pair = summary.details["pairs"][0]
    assert pair["start_error"] > 0.5  # its home pose is not the leader's
    assert pair["align_s"] is not None and pair["align_s"] < 3.5, summary.format()
    assert pair["final_error"] < 0.08, summary.format()

# -- errors: one line naming the port and the id ----------------------------------------------------
def _one_line(e):
    text = str(e.value)
    assert "\n" not in text, text
    return text


def test_unplugged_leader_names_the_port():
    with pytest.raises(BusError) as e:
        DynamixelBus("/dev/serial/by-id/usb-FTDI_gone-if00-port0").open()
    assert "/dev/serial/by-id/usb-FTDI_gone-if00-port0" in _one_line(e) and "U2D2" in _one_line(e)


def test_wrong_or_missing_ids_name_port_and_id(gello, tmp_path):
    g = gello("ur5e")
    g.bus.servo(3).responsive = False  # a loose cable, or a servo still at its factory id
    cal_file = save_calibration(g.mounting, tmp_path / "v.json")
    node = GelloLeader(port=g.port, layout="ur5e", calibration=str(cal_file))
    node.setup()
    with pytest.raises(BusError) as e:
        with lifecycle(node):
            pass
    text = _one_line(e)
    assert g.port in text and "id 3 (joint3) did not answer" in text and "[1, 2, 4, 5, 6, 7]" in text
    # nothing at all on the bus (unpowered leader)
    with DynamixelBusEmulator([]) as empty, pytest.raises(BusError) as e:
        with DynamixelBus(empty.port, label="/dev/ttyUSB0") as bus:
            bus.check_present([1, 2])
    assert "/dev/ttyUSB0" in _one_line(e) and "ids that did: none" in _one_line(e)


def test_a_servo_lost_while_running_is_named(gello, tmp_path):
    g = gello("xarm7")
    cal_file = save_calibration(g.mounting, tmp_path / "v.json")
    node = GelloLeader(port=g.port, layout="xarm7", calibration=str(cal_file), retries=1)
    node.setup()
    with lifecycle(node):
        node.read_state()
        g.bus.servo(5).responsive = False
        with pytest.raises(BusError) as e:
            node.read_state()
    assert "id 5 (joint5) did not answer the position read" in _one_line(e) and g.port in _one_line(e)


def test_missing_calibration_says_how_to_make_one(gello):
    g = gello("fr3")
    node = GelloLeader(port=g.port, layout="fr3", calibration="left")
    node.setup()
    with pytest.raises(CalibrationError) as e:
        with lifecycle(node):
            pass
    assert f"rio gello calibrate --port {g.port} --layout fr3 --name left" in _one_line(e)


def test_a_station_with_a_missing_leader_fails_with_that_line(tmp_path):
    st = _station("/dev/ttyUSB_nothing_here", tmp_path / "none.json")
    with pytest.raises(RioError, match="/dev/ttyUSB_nothing_here"):
        run_teleop(st, duration=0.5, log=None)
