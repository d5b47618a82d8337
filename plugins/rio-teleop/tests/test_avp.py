"""teleop.avp against an emulated Tracking Streamer app (`rio_teleop.avp.emulator`), through the unmodified
avp-stream SDK: the emulator serves the app's real gRPC service with avp-stream's own generated messages,
on a loopback address of its own (the SDK always dials port 12345), and the node's `VisionProStreamer`
dials it, parses and converts the updates with the SDK's code. What the tests fix: the published frame
(the emulated hand in visionOS world axes, turned to x forward, y left, z up), the keypoints, the pinch
gripper, when a hand counts as tracked, the errors a user meets, that close() leaves no thread or
connection behind, and that `rio teleop` drives a fake arm with it. `-m hardware` with RIO_AVP_IP set
checks a real headset."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import threading
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from rio.conformance.drivers import TeleopConformance
from rio.control.rotations import quat_to_matrix, rotvec_to_quat
from rio.emulation import free_loopback
from rio.errors import RioError
from rio.interfaces.teleop import HAND_JOINTS, LEFT, RIGHT
from rio.testing import block_import, fake_eef_station, lifecycle, skip_tests_without, wait_until

# found, not imported: avp_stream imports scipy.spatial (0.8 s in every test process) and sets signal handlers
skip_tests_without("avp_stream")

from rio_teleop.avp import emulator as em  # noqa: E402
from rio_teleop.avp.node import SDK_TO_ROBOT, VISIONOS_JOINTS, VisionProTeleop  # noqa: E402

#: visionOS world (x right, y up, z toward the wearer) -> robot (x forward, y left, z up), written out:
#: forward is -z, left is -x, up is +y.
APP_TO_ROBOT = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
TIP, THUMB_TIP, INDEX_TIP = HAND_JOINTS.index("middle-finger-tip"), HAND_JOINTS.index("thumb-tip"), \
    HAND_JOINTS.index("index-finger-tip")


def sdk_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name.startswith("avp-stream ")]


@pytest.fixture(scope="module", autouse=True)
def no_thread_left_behind():
    """After the module: every SDK thread a node started has ended (one still in the SDK's 5 s channel
    wait after a failed open ends with it)."""
    yield
    assert wait_until(lambda: not sdk_threads(), timeout=15.0), [t.name for t in sdk_threads()]


@pytest.fixture
def emu():
    """An emulator with a still scene and tracking noise of 10 um (changes every pose's bits, as real
    tracking does, far below the tolerances)."""
    e = em.TrackingStreamerEmulator(em.still(), noise_m=1e-5).start()
    yield e
    e.stop()


@contextmanager
def opened(emulator, **config):
    node = VisionProTeleop(ip=emulator.host, connect_timeout_s=10.0, **config)
    with lifecycle(node):
        yield node


def settled(node, pred, timeout=5.0):
    """The first sample for which pred(sample) holds (waiting up to `timeout` s)."""
    got = {}

    def check():
        got["s"] = node.read_state()
        return pred(got["s"])

    assert wait_until(check, timeout=timeout), f"never reached; last sample {got.get('s')}"
    return got["s"]


def both_tracked(s):
    return bool(s["tracked"].all())


def turned(rotvec) -> np.ndarray:
    return em.PALM_DOWN @ quat_to_matrix(rotvec_to_quat(rotvec))


# -- the frame -------------------------------------------------------------------------------------------
def test_the_published_frame_is_the_sdks_z_up_frame_turned_to_the_robot_axes():
    from rio_teleop.avp.loader import import_avp  # (a bare import of the SDK takes over SIGINT and SIGTERM)
    from rio_teleop.webxr.mapping import XR_TO_ROBOT

    streamer = import_avp()
    JOINT_NAMES, YUP2ZUP = streamer.JOINT_NAMES, streamer.YUP2ZUP  # noqa: N806 (the SDK's names)

    # the SDK's YUP2ZUP, then ours: the visionOS world in robot axes, the same turn as the WebXR page's
    assert np.array_equal(SDK_TO_ROBOT @ YUP2ZUP[0, :3, :3], APP_TO_ROBOT)
    assert np.array_equal(APP_TO_ROBOT, XR_TO_ROBOT)
    # every HAND_JOINTS joint has its visionOS joint; their orders agree (the contract calls it one skeleton)
    assert [JOINT_NAMES[VISIONOS_JOINTS[j]] for j in HAND_JOINTS] == list(range(25))


def test_wrist_poses_and_keypoints_are_the_sent_hands_in_robot_axes(emu):
    right = em.pose([0.25, 1.15, -0.4], turned([0.3, -0.5, 0.2]))
    left = em.pose([-0.3, 0.95, -0.2], turned([-0.2, 0.1, 0.6]))
    emu.motion = em.still(em.Scene(left=em.Hand(left), right=em.Hand(right, pinch=0.3)))
    with opened(emu) as node:
        s = settled(node, both_tracked)
    sent = {m.seq: m for m in emu.sent()}
    # the sample is one message the emulator sent (float32 on the wire), turned to robot axes
    match = [m for m in sent.values()
             if np.allclose(s["wrist_pose"][RIGHT, :3], APP_TO_ROBOT @ m.right_wrist[:3, 3], atol=1e-6)]
    assert len(match) == 1, "no (or more than one) sent message has the published right wrist"
    m = match[0]
    for h, wrist, joints in ((LEFT, m.left_wrist, m.left_joints), (RIGHT, m.right_wrist, m.right_joints)):
        w = wrist.astype(np.float64)
        assert np.allclose(s["wrist_pose"][h, :3], APP_TO_ROBOT @ w[:3, 3], atol=1e-6)
        assert np.allclose(quat_to_matrix(s["wrist_pose"][h, 3:]), APP_TO_ROBOT @ w[:3, :3], atol=1e-6)
        world = (w @ joints.astype(np.float64))[:25, :3, 3]  # the joints are sent relative to the wrist
        kp = s["hand_keypoints"][h]
        assert np.allclose(kp, world @ APP_TO_ROBOT.T, atol=1e-6)
        assert np.allclose(kp[0], s["wrist_pose"][h, :3], atol=1e-9)  # keypoint 0 is the wrist
        reach = np.linalg.norm(kp[1:] - kp[0], axis=1)
        assert 0.01 < reach.min() and reach.max() < 0.25 and 0.15 < reach[TIP - 1] < 0.22
    pinch = np.linalg.norm(s["hand_keypoints"][RIGHT, THUMB_TIP] - s["hand_keypoints"][RIGHT, INDEX_TIP])
    assert pinch == pytest.approx(0.7 * em.OPEN_PINCH_DISTANCE, abs=1e-6)
    assert s["twist"].shape == (6,) and not s["twist"].any()
    assert s["buttons"].shape == (2,) and not s["buttons"].any()


@pytest.mark.parametrize("yaw_deg", [0.0, 90.0])
def test_forward_left_and_up_move_the_wrist_along_x_y_and_z(emu, yaw_deg):
    """Moving the hand away from the wearer, to their left and up moves the published wrist along +x, +y
    and +z; yaw_deg = 90 turns that counter-clockwise (forward becomes +y)."""
    p0 = np.array([0.2, 1.1, -0.35])
    emu.motion = em.still(em.Scene(right=em.Hand(em.pose(p0))))
    yaw = np.deg2rad(yaw_deg)
    rz = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]])
    with opened(emu, yaw_deg=yaw_deg) as node:
        start = settled(node, both_tracked)["wrist_pose"][RIGHT]
        for app_move, robot_move in (([0, 0, -0.1], [0.1, 0, 0]), ([-0.1, 0, 0], [0, 0.1, 0]),
                                     ([0, 0.1, 0], [0, 0, 0.1])):
            emu.motion = em.still(em.Scene(right=em.Hand(em.pose(p0 + app_move))))
            want = start[:3] + rz @ robot_move
            settled(node, lambda s, want=want: np.allclose(s["wrist_pose"][RIGHT, :3], want, atol=2e-4))
        if yaw_deg == 0:  # palm down, fingers forward is the identity in robot axes for the emulated wrist
            assert np.allclose(np.abs(start[3:]), [1, 0, 0, 0], atol=1e-5)


# -- the gripper -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("hand", ["right", "left"])
def test_a_pinch_of_the_configured_hand_closes_the_gripper(emu, hand):
    other = "left" if hand == "right" else "right"
    scene = em.Scene()
    emu.motion = em.still(scene)
    with opened(emu, hand=hand) as node:
        assert settled(node, both_tracked)["gripper"] == 1.0  # open hand: open gripper
        emu.motion = em.still(em.with_hand(scene, other, pinch=1.0))
        time.sleep(0.2)
        assert settled(node, both_tracked)["gripper"] == 1.0  # the other hand's pinch does nothing
        emu.motion = em.still(em.with_hand(scene, hand, pinch=1.0))
        settled(node, lambda s: s["gripper"] == 0.0)
        emu.motion = em.still(em.with_hand(scene, hand, pinch=0.5))  # tips 4.6 cm apart: half open
        half = settled(node, lambda s: 0.0 < s["gripper"] < 1.0)["gripper"]
        assert half == pytest.approx((0.5 * em.OPEN_PINCH_DISTANCE - 0.015) / 0.065, abs=1e-3)
        emu.motion = em.still(scene)
        settled(node, lambda s: s["gripper"] == 1.0)


# -- tracked ---------------------------------------------------------------------------------------------
def test_a_silent_or_stopped_app_untracks_both_hands_after_stale_s(emu):
    stale_s, margin = 0.3, 3.0  # the margin only bounds the wait on a loaded machine
    with opened(emu, stale_s=stale_s) as node:
        settled(node, both_tracked)
        emu.paused = True  # the stream stays open, nothing comes (the app in the background)
        s = settled(node, lambda s: not s["tracked"].any(), timeout=stale_s + margin)
        assert node.status()["age_s"] >= stale_s
        assert np.isfinite(s["wrist_pose"]).all()  # the last values stay, marked stale
        emu.paused = False
        settled(node, both_tracked)
        emu.stop()  # the app quits: the connection drops
        settled(node, lambda s: not s["tracked"].any(), timeout=stale_s + margin)
        assert node.status()["age_s"] >= stale_s


def test_a_hand_the_headset_loses_is_untracked_and_the_gripper_holds(emu):
    """The app keeps sending a lost hand's last pose: the frozen hand is untracked after stale_s while
    the other stays tracked; the gripper keeps the lost hand's last pinch."""
    scene = em.Scene(right=em.Hand(pinch=1.0))
    emu.motion = em.still(scene)
    with opened(emu, stale_s=0.3) as node:
        before = settled(node, lambda s: both_tracked(s) and s["gripper"] == 0.0)
        emu.motion = em.still(em.with_hand(scene, "right", tracked=False))
        s = settled(node, lambda s: not s["tracked"][RIGHT], timeout=4.0)
        assert s["tracked"][LEFT] and s["gripper"] == 0.0
        assert np.allclose(s["wrist_pose"][RIGHT], before["wrist_pose"][RIGHT], atol=1e-3)
        emu.motion = em.still(em.with_hand(scene, "right", pinch=0.0))  # back, open
        settled(node, lambda s: both_tracked(s) and s["gripper"] == 1.0)


def test_a_hand_never_tracked_is_not_tracked(emu):
    """Until the headset first sees a hand the app sends the identity for it: never tracked."""
    emu.motion = em.still(em.Scene(left=em.Hand(tracked=False)))
    with opened(emu, stale_s=0.3) as node:
        settled(node, lambda s: s["tracked"][RIGHT])
        time.sleep(0.4)
        assert not node.read_state()["tracked"][LEFT]


# -- errors and cleanup ----------------------------------------------------------------------------------
def test_an_app_that_does_not_answer_fails_open_with_the_address_port_and_checklist():
    ip = free_loopback([em.GRPC_PORT])  # nothing listens there
    node = VisionProTeleop(ip=ip, connect_timeout_s=0.3)
    t0 = time.monotonic()
    with pytest.raises(RioError) as ei:
        node.open()
    assert time.monotonic() - t0 < 5.0  # the configured wait, not the SDK's endless one
    text = str(ei.value)
    assert f"{ip}:12345" in text and "same network" in text and "Local Network" in text
    assert "Tracking Streamer" in text and "12345" in text
    node.close()


def test_missing_avp_stream_names_the_extra(monkeypatch):
    block_import(monkeypatch, "avp_stream")
    node = VisionProTeleop(ip="127.0.0.1")
    with pytest.raises(RioError, match=r"teleop\.avp needs avp-stream .*pip install 'rio-teleop\[avp\]'"):
        node.open()


def test_an_app_refusing_this_sdk_version_is_named():
    with em.TrackingStreamerEmulator(min_version_code=99_00_00) as e:
        with pytest.raises(RioError, match="refuses this avp-stream version"):
            VisionProTeleop(ip=e.host, connect_timeout_s=10.0).open()
        assert e.clients and e.clients[0]["version_code"] > 0 and e.clients[0]["discovery"]


@pytest.mark.parametrize("paused", [False, True])
def test_close_ends_the_sdk_thread_and_its_connection(emu, paused):
    """Streaming or blocked on a silent stream, close() ends the SDK's thread and the call at once; the
    SDK's HTTP info server (port 8888, WebRTC only) is not started."""
    node = VisionProTeleop(ip=emu.host)
    node.open()
    streamer = node.streamer
    assert wait_until(lambda: emu.streams == 1)
    assert streamer.info_server is None
    emu.paused = paused
    time.sleep(0.1)
    node.close()
    assert wait_until(lambda: not streamer.rio_thread.is_alive()), "the SDK's thread outlived close()"
    assert wait_until(lambda: emu.streams == 0), "the emulator still streams to a closed node"
    emu.paused = False
    node.open()  # the same node opens again
    assert node.read_state()["wrist_pose"].shape == (2, 7)
    node.close()


def test_reconnects_when_the_app_comes_back(emu):
    host = emu.host
    with opened(emu, stale_s=0.3) as node:
        settled(node, both_tracked)
        emu.stop()
        settled(node, lambda s: not s["tracked"].any())
        with em.TrackingStreamerEmulator(em.still(), host=host, noise_m=1e-5):
            settled(node, both_tracked, timeout=12.0)  # the SDK's own retry dials again


def test_the_sdk_keeps_out_of_the_process_signals_and_output():
    """avp_stream registers SIGINT/SIGTERM handlers at import, prints, and gRPC logs connection events to
    stderr; a RIO node process keeps its own handlers, and opening, streaming, losing the app and failing
    to connect print nothing (a fresh interpreter, so the import and gRPC's start-up happen here)."""
    code = textwrap.dedent("""
        import signal, time
        def mine(*a): pass
        signal.signal(signal.SIGTERM, mine)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        from rio.errors import RioError
        from rio.emulation import free_loopback
        from rio_teleop.avp.loader import import_avp
        from rio_teleop.avp.emulator import TrackingStreamerEmulator
        from rio_teleop.avp.node import VisionProTeleop
        streamer = import_avp("avp_stream.streamer")
        assert hasattr(streamer, "_signal_handler")  # the SDK's, which it installs at import
        assert signal.getsignal(signal.SIGTERM) is mine
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        emu = TrackingStreamerEmulator().start()
        node = VisionProTeleop(ip=emu.host)
        node.open()
        time.sleep(0.2)
        node.read_state()
        emu.stop()  # the app goes away mid-stream
        time.sleep(0.3)
        node.close()
        try:
            VisionProTeleop(ip=free_loopback([12345]), connect_timeout_s=0.2).open()
        except RioError:
            pass
        print("kept")
    """)
    env = {k: v for k, v in os.environ.items() if k != "GRPC_VERBOSITY"}  # gRPC's default, as a user has it
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, env=env)
    assert out.returncode == 0, out.stderr
    assert out.stdout == "kept\n" and out.stderr == "", (out.stdout, out.stderr)


# -- the conformance kit and rio teleop ---------------------------------------------------------------------
class TestVisionProConformance(TeleopConformance):
    """The teleop driver kit against a fresh emulator per case."""

    driver = "teleop.avp"
    config = {"connect_timeout_s": 10.0}
    bad_config = {"ip": free_loopback([em.GRPC_PORT]), "connect_timeout_s": 0.2}  # nothing serves it

    @contextmanager
    def emulator(self):
        with em.TrackingStreamerEmulator() as e:
            yield {"ip": e.host}


STATION = fake_eef_station("avp-eef", 'driver = "teleop.avp"\nip = "{ip}"')


class Reach:
    """Scripted: still until `go()`, then the right hand moves forward 6 cm, left 3 cm and up 2 cm over
    0.6 s, and pinches 0.5 s later."""

    p0 = np.array([0.2, 1.1, -0.35])

    def __init__(self):
        self.t_go: float | None = None

    def go(self) -> None:
        if self.t_go is None:
            self.t_go = time.monotonic()

    def __call__(self, t: float) -> em.Scene:
        k = 0.0 if self.t_go is None else (time.monotonic() - self.t_go - 0.5) / 0.6
        k = min(max(k, 0.0), 1.0)
        p = self.p0 + k * np.array([-0.03, 0.02, -0.06])  # app frame: left is -x, up +y, forward -z
        pinch = 1.0 if self.t_go is not None and time.monotonic() - self.t_go > 1.6 else 0.0
        return em.Scene(right=em.Hand(em.pose(p), pinch=pinch))


def test_rio_teleop_moves_a_fake_arm_with_the_emulated_hand(tmp_path):
    from rio.workflows.teleop import run_teleop

    reach = Reach()
    with em.TrackingStreamerEmulator(reach, noise_m=1e-5) as e:
        path = Path(tmp_path) / "avp.toml"
        path.write_text(STATION.format(ip=e.host))
        ticks = []

        def on_tick(tick):
            reach.go()
            ticks.append(tick)

        run_teleop(str(path), duration=3.0, on_tick=on_tick, log=None)
    first, last = ticks[0].step.observation, ticks[-1].step.observation
    assert np.allclose(last.proprio_eef[:3] - first.proprio_eef[:3], [0.06, 0.03, 0.02], atol=3e-3)
    assert first.gripper_width == pytest.approx(0.08, abs=1e-3)
    assert last.gripper_width < 0.01  # the pinch closed it


# -- a real headset -----------------------------------------------------------------------------------------
@pytest.mark.hardware
def test_real_vision_pro_streams_hands():
    """RIO_AVP_IP=<the address Tracking Streamer shows> with the app open and your hands in view."""
    ip = os.environ.get("RIO_AVP_IP")
    if not ip:
        pytest.skip("set RIO_AVP_IP to the address Tracking Streamer shows")
    with lifecycle(VisionProTeleop(ip=ip, connect_timeout_s=20.0)) as node:
        t_end, samples, seen = time.monotonic() + 3.0, [], np.zeros(2, bool)
        while time.monotonic() < t_end:
            s = node.read_state()
            samples.append(s)
            seen |= s["tracked"]
            time.sleep(1 / 90)
        assert node.status()["samples"] > 100  # the app streams at ~200 Hz
    assert seen.any(), "no hand was tracked in 3 s: hold your hands in front of the headset"
    for s in samples:
        for h in np.flatnonzero(s["tracked"]):
            kp = s["hand_keypoints"][h]
            assert np.allclose(kp[0], s["wrist_pose"][h, :3], atol=0.02)
            assert np.linalg.norm(kp[1:] - kp[0], axis=1).max() < 0.3
