"""teleop.webxr's parts alone: the message check, the clutch mapping, the hands mapping
(teleop.webxr_hands), the TLS certificate."""

from __future__ import annotations

import datetime
import json
import ssl

import numpy as np
import pytest
from rio_teleop.webxr import protocol
from rio_teleop.webxr.certs import ensure_certificate
from rio_teleop.webxr.harness import CHROMIUM, hands_message, synthetic_hand
from rio_teleop.webxr.harness import input_message as msg
from rio_teleop.webxr.mapping import ClutchMapper, HandMapper

from rio.control.rotations import quat_rotate
from rio.interfaces.teleop import HAND_JOINTS, hand_tracker_sample


# -- protocol ------------------------------------------------------------------------------------------
def test_a_valid_input_message_parses_and_its_quaternion_is_normalised():
    m = protocol.parse(json.dumps(msg([0.1, 1.2, -0.3], [0, 0, 0, 1.25], clutch=True, trigger=0.5)))
    assert m["pose"]["q"] == [0, 0, 0, 1.0] and m["clutch"] and m["trigger"] == 0.5


@pytest.mark.parametrize("raw, why", [
    ('{"type": "ping", "id": 1, "t": NaN}', "not a number"),
    ('{"type": "ping", "id": 1, "t": Infinity}', "not a number"),
    ('{"type": "ping", "id": 1, "t": 1e999}', "not finite"),
    ('{"type": "ping", "id": true, "t": 0}', "integer"),
    ('{"type": "ping", "id": 1}', "missing"),
    (json.dumps({**msg([0, 0, 0]), "trigger": 1.5}), "out of range"),
    (json.dumps(msg([0, 0, 25.0])), "out of range"),
    (json.dumps(msg([0, 0, 0], [0, 0, 0, 0.1])), "not a rotation"),
    (json.dumps({**msg([0, 0, 0]), "source": "x" * 40}), "source"),
    (json.dumps({**msg(), "pose": {"p": [0, 0, 0]}}), "pose"),
    ("x" * (protocol.MAX_HANDS_BYTES + 1), "limit"),
    ("é" * (protocol.MAX_HANDS_BYTES // 2 + 1), "over"),
    (json.dumps({**msg([0, 0, 0]), "source": "x" * 3000}), "over 2048 bytes"),  # only hands may be longer
    (json.dumps({"type": "ping", "id": 1, "t": 0, "pad": " " * 3000}), "over 2048 bytes"),
    (b"{}", "binary"),
    ("[" * 3000, "not JSON"),
    ("[" * 9000, "characters"),
])
def test_bad_messages_are_refused_with_a_reason(raw, why):
    with pytest.raises(protocol.ProtocolError, match=why):
        protocol.parse(raw)


# -- protocol: hands ---------------------------------------------------------------------------------
Q_TURNED = [0.1, 0.2, 0.3, float(np.sqrt(1 - 0.14))]  # unrounded doubles everywhere


def _hands(**kw):
    return hands_message(left=synthetic_hand([-0.2, 1.1, -0.3], Q_TURNED),
                         right=synthetic_hand([0.2, 1.1, -0.3], Q_TURNED), **kw)


def test_a_valid_hands_message_parses_and_fits_its_limit():
    m = _hands(seq=7)
    raw = json.dumps(m)
    assert protocol.MAX_BYTES < len(raw) <= protocol.MAX_HANDS_BYTES  # unrounded doubles: over input's limit
    out = protocol.parse(raw)
    assert out["type"] == "hands" and out["seq"] == 7 and len(out["left"]["j"]) == len(HAND_JOINTS) == 25
    assert np.asarray(out["right"]["j"]) == pytest.approx(np.asarray(m["right"]["j"]))
    assert out["left"]["q"] == pytest.approx(Q_TURNED)
    both_gone = protocol.parse(json.dumps(hands_message(None, None)))
    assert both_gone["left"] is None and both_gone["right"] is None
    q = protocol.parse(json.dumps(hands_message(right={**synthetic_hand(), "q": [0, 0, 0, 1.2]})))["right"]["q"]
    assert q == [0, 0, 0, 1.0]  # normalised
    rounded = {**m, "left": {"j": [[round(x, 4) for x in p] for p in m["left"]["j"]], "q": [0, 0, 0, 1]}}
    rounded["right"] = rounded["left"]
    assert len(json.dumps(rounded, separators=(",", ":"))) < 1600  # as the page sends it


def _bad_hand(**change):
    return json.dumps({**_hands(), "right": {**synthetic_hand(), **change}})


@pytest.mark.parametrize("raw, why", [
    (json.dumps({**_hands(), "right": {"j": synthetic_hand()["j"][:24], "q": [0, 0, 0, 1]}}), "25 joints"),
    (json.dumps({**_hands(), "right": {"j": synthetic_hand()["j"] + [[0, 1, 0]], "q": [0, 0, 0, 1]}}), "25 joints"),
    (json.dumps({**_hands(), "right": {"j": {"wrist": [0, 0, 0]}, "q": [0, 0, 0, 1]}}), "25 joints"),
    (_bad_hand(j=[[0.0, 1.2]] + synthetic_hand()["j"][1:]), r"right.j\[0\]: a list of 3"),
    (_bad_hand(j=[[0.0, 1.2, True]] + synthetic_hand()["j"][1:]), "not a finite number"),
    (_bad_hand(j=[[0.0, 1.2, "0"]] + synthetic_hand()["j"][1:]), "not a finite number"),
    (_bad_hand(j=[[0.0, 1.2, 25.0]] + synthetic_hand()["j"][1:]), "out of range"),
    (_bad_hand(j=synthetic_hand()["j"][:24] + [[0.0, 1.2, -1.3]]), "from the wrist"),
    (_bad_hand(j=synthetic_hand()["j"][:24] + [[0.0, 1.2, -0.33]]).replace("-0.33", "NaN"), "not a number"),
    (_bad_hand(j=synthetic_hand()["j"][:24] + [[0.0, 1.2, -0.33]]).replace("-0.33", "-Infinity"), "not a number"),
    (_bad_hand(j=synthetic_hand()["j"][:24] + [[0.0, 1.2, -0.33]]).replace("-0.33", "1e999"), "not a finite"),
    (_bad_hand(q=[0, 0, 0, 0.1]), "right.q: not a rotation"),
    (_bad_hand(q=[0, 0, 0, 0]), "not a rotation"),
    (_bad_hand(q=[0, 0, 1]), "right.q: a list of 4"),
    (_bad_hand(q=[0, 0, 0, 2.0]), "out of range"),
    (_bad_hand(extra=1), "right: null or"),
    (json.dumps({**_hands(), "right": [0, 1, 2]}), "right: null or"),
    (json.dumps({**_hands(), "left": True}), "left: null or"),
    (json.dumps({**_hands(), "extra": 1}), "unknown keys"),
    (json.dumps({k: v for k, v in _hands().items() if k != "left"}), "missing"),
    (json.dumps({**_hands(), "seq": -1}), "non-negative integer"),
    (json.dumps({**_hands(), "t": "now"}), "a number"),
    (json.dumps({**_hands(), "pad": "x" * protocol.MAX_HANDS_BYTES}), "limit"),
])
def test_bad_hands_messages_are_refused_with_a_reason(raw, why):
    with pytest.raises(protocol.ProtocolError, match=why):
        protocol.parse(raw)


# -- mapping -------------------------------------------------------------------------------------------
def _feed(m: ClutchMapper, p, t, clutch=True, q=(0, 0, 0, 1)):
    m.on_input(protocol.parse(json.dumps(msg(p, q, clutch=clutch))), t)


def _integrate(m: ClutchMapper, t0, t1, dt=0.01):
    """Step the mapper like the node does (keeping the stream fresh) and integrate its twist."""
    pos, t = np.zeros(6), t0
    prev = None
    while t < t1:
        m.t_msg = t  # the page keeps streaming the same pose
        tw = m.step(t)["twist"]
        if prev is not None:
            pos += 0.5 * (prev + tw) * dt
        prev, t = tw, t + dt
    return pos


def test_pose_mapping_lands_on_the_controllers_displacement_in_the_robot_frame():
    m = ClutchMapper(max_speed=0.15)
    m.connect(0.0)
    _feed(m, [0, 1, 0], 0.0, clutch=False)
    _feed(m, [0, 1, 0], 0.0)
    _feed(m, [-0.02, 1.03, -0.1], 0.0)  # XR: left 2 cm, up 3 cm, forward 10 cm
    moved = _integrate(m, 0.0, 2.0)
    assert moved[:3] == pytest.approx([0.10, 0.02, 0.03], abs=2e-4)
    assert np.abs(m.step(2.0)["twist"]).max() == 0  # settled: nothing more is sent


def test_yaw_turns_the_mapping_and_scale_scales_it():
    m = ClutchMapper(yaw_deg=90, scale=0.5)
    m.connect(0.0)
    _feed(m, [0, 1, 0], 0.0, clutch=False)
    _feed(m, [0, 1, 0], 0.0)
    _feed(m, [0, 1, -0.1], 0.0)
    assert _integrate(m, 0.0, 2.0)[:3] == pytest.approx([0.0, 0.05, 0.0], abs=2e-4)


def test_rotation_follows_the_controller():
    m = ClutchMapper(max_rot_speed=2.0)
    m.connect(0.0)
    _feed(m, [0, 1, 0], 0.0, clutch=False)
    _feed(m, [0, 1, 0], 0.0)
    a = 0.3  # about XR +y (up) = robot +z
    _feed(m, [0, 1, 0], 0.0, q=(0, np.sin(a / 2), 0, np.cos(a / 2)))
    assert _integrate(m, 0.0, 2.0)[3:] == pytest.approx([0, 0, a], abs=2e-3)


def test_twist_mapping_is_rate_control_with_a_dead_band():
    m = ClutchMapper(mapping="twist", twist_gain=2.0, dead_band_m=0.01)
    m.connect(0.0)
    _feed(m, [0, 1, 0], 0.0, clutch=False)
    _feed(m, [0, 1, 0], 0.0)
    _feed(m, [0, 1, -0.005], 0.0)
    assert np.abs(m.step(0.01)["twist"]).max() == 0  # inside the dead band
    _feed(m, [0, 1, -0.06], 0.01)
    assert m.step(0.02)["twist"][:3] == pytest.approx([0.1, 0, 0])  # (6 - 1) cm * 2 /s
    _feed(m, [0, 1, -0.06], 0.02, clutch=False)
    assert np.abs(m.step(0.03)["twist"]).max() == 0


def test_clutch_needs_a_fresh_press_after_connecting_and_after_a_drop_out():
    m = ClutchMapper(stale_s=0.25)
    m.connect(0.0)
    _feed(m, [0, 1, 0], 0.0)  # held down from before: ignored
    _feed(m, [0, 1, -0.1], 0.01)
    assert not m.engaged and np.abs(_integrate(m, 0.01, 0.5)).max() == 0
    _feed(m, [0, 1, -0.1], 0.5, clutch=False)
    _feed(m, [0, 1, -0.1], 0.51)
    assert m.engaged
    _feed(m, [0, 1, -0.2], 0.52)
    m.step(0.52)
    s = m.step(0.9)  # nothing for 0.38 s: stale
    assert np.abs(s["twist"]).max() == 0 and not m.engaged and m.held_count == 1
    _feed(m, [0, 1, -0.3], 0.95)  # the stream is back, clutch still down: not followed
    assert not m.engaged and np.abs(m.step(0.96)["twist"]).max() == 0


def test_buttons_and_gripper():
    m = ClutchMapper(buttons=2)
    m.connect(0.0)
    m.on_input(protocol.parse(json.dumps(msg(None, trigger=0.75, mode=True))), 0.0)
    s = m.step(0.0)
    assert s["gripper"] == 0.25 and s["buttons"].tolist() == [True, False]
    assert m.step(0.01)["buttons"].tolist() == [False, False]  # a press is published once
    m.on_input(protocol.parse(json.dumps(msg(None, done=True))), 0.02)
    assert m.step(0.02)["buttons"].tolist() == [False, True]


# -- certificate -------------------------------------------------------------------------------------
def test_the_certificate_is_valid_private_and_stable_across_restarts(tmp_path):
    from cryptography import x509

    a = ensure_certificate(tmp_path / "c", names=["192.168.1.7", "robot-pc"])
    assert (a.cert.stat().st_mode & 0o777) == 0o644 and (a.key.stat().st_mode & 0o777) == 0o600
    cert = x509.load_pem_x509_certificate(a.cert.read_bytes())
    assert set(a.names) == {"localhost", "127.0.0.1", "192.168.1.7", "robot-pc"}
    assert cert.not_valid_after_utc > datetime.datetime.now(datetime.timezone.utc) + datetime.timedelta(days=800)
    ctx = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
    ctx.load_cert_chain(str(a.cert), str(a.key))  # the key matches; Python's TLS accepts it
    assert len(a.fingerprint.split(":")) == 32
    b = ensure_certificate(tmp_path / "c", names=["192.168.1.7"])  # a restart: the same certificate
    assert b.fingerprint == a.fingerprint


def test_the_certificate_is_made_again_when_expired_or_missing_an_address(tmp_path):
    a = ensure_certificate(tmp_path / "c")
    later = datetime.datetime.now(datetime.timezone.utc) + datetime.timedelta(days=900)
    b = ensure_certificate(tmp_path / "c", now=later)
    assert b.fingerprint != a.fingerprint and b.not_after > later
    c = ensure_certificate(tmp_path / "c", names=["10.0.0.5"], now=later)
    assert c.fingerprint != b.fingerprint and "10.0.0.5" in c.names
    (tmp_path / "c" / "cert.pem").write_text("garbage")
    assert ensure_certificate(tmp_path / "c").fingerprint not in (a.fingerprint, c.fingerprint)


def test_the_node_keeps_its_fingerprint_across_restarts(tmp_path):
    pytest.importorskip("aiohttp")
    from rio_teleop.webxr.node import WebXRTeleop

    from rio.testing import lifecycle

    prints = []
    for _ in range(2):
        node = WebXRTeleop(port=0, cert_dir=str(tmp_path / "cert"))
        node.setup()
        with lifecycle(node):
            prints.append(node.page()["fingerprint"])
    assert prints[0] == prints[1]


# -- hands mapping (teleop.webxr_hands) ---------------------------------------------------------------
def _hand_mapper(**kw) -> HandMapper:
    m = HandMapper(**kw)
    m.connect(0.0)
    return m


def _on_hands(m: HandMapper, t: float, left=None, right=None):
    m.on_hands(protocol.parse(json.dumps(hands_message(left, right))), t)


def test_hands_are_published_in_the_robots_axes():
    m = _hand_mapper()
    before = m.step(0.0)
    assert not before["tracked"].any() and before["gripper"] == 1.0  # open until a hand is seen
    right = synthetic_hand([0.1, 1.2, -0.3])  # XR: 10 cm right, 1.2 m up, 30 cm ahead
    _on_hands(m, 0.0, right=right)
    s = m.step(0.01)
    sample = hand_tracker_sample()
    assert {k: np.shape(v) for k, v in s.items() if k in sample} == {k: v.shape for k, v in sample.items()}
    assert s["tracked"].tolist() == [False, True] and s["tracked"].dtype == bool
    assert s["wrist_pose"][1, :3] == pytest.approx([0.3, -0.1, 1.2])  # robot: x forward, y left, z up
    xr = np.asarray(right["j"])
    assert s["hand_keypoints"][1] == pytest.approx(np.stack([-xr[:, 2], -xr[:, 0], xr[:, 1]], axis=1))
    # the wrist's orientation is the world turned: the hand's -z (its fingers, XR forward) is robot +x
    assert quat_rotate(s["wrist_pose"][1, 3:], [0, 0, -1]) == pytest.approx([1, 0, 0])
    assert np.abs(s["twist"]).max() == 0 and s["buttons"].tolist() == [False, False]


def test_hands_yaw_turns_the_hands_and_the_wrist_orientation_follows_the_hand():
    m = _hand_mapper(yaw_deg=90)
    a = 0.4  # the hand turned about XR +y (up): robot +z
    q = [0.0, np.sin(a / 2), 0.0, np.cos(a / 2)]
    _on_hands(m, 0.0, left=synthetic_hand([0.0, 1.0, -0.3], q))
    s = m.step(0.0)
    assert s["tracked"].tolist() == [True, False]
    assert s["wrist_pose"][0, :3] == pytest.approx([0.0, 0.3, 1.0])  # forward 0.3 m, turned 90 deg: left
    fingers = quat_rotate(s["wrist_pose"][0, 3:], [0, 0, -1])
    assert fingers == pytest.approx([-np.sin(a), np.cos(a), 0.0])  # 90 deg + a about z
    kp = s["hand_keypoints"][0]
    tip = kp[HAND_JOINTS.index("middle-finger-tip")] - kp[0]
    assert tip / np.linalg.norm(tip) == pytest.approx([-np.sin(a), np.cos(a), 0.0], abs=0.15)


def test_a_hand_goes_untracked_when_its_stream_is_stale_gone_or_disconnected():
    m = _hand_mapper(stale_s=0.25)
    _on_hands(m, 0.0, left=synthetic_hand([-0.2, 1.2, -0.3]), right=synthetic_hand([0.2, 1.2, -0.3]))
    assert m.step(0.2)["tracked"].tolist() == [True, True]
    s = m.step(0.3)  # nothing for 0.3 s
    assert s["tracked"].tolist() == [False, False] and m.status(0.3)["stale"]
    assert s["wrist_pose"][0, :3] == pytest.approx([0.3, 0.2, 1.2])  # the last values stay
    _on_hands(m, 0.4, right=synthetic_hand([0.2, 1.2, -0.3]))  # the left hand is reported lost
    assert m.step(0.41)["tracked"].tolist() == [False, True]
    st = m.status(0.41)
    assert st["hands"] == {"left": False, "right": True} and st["engaged"] and not st["stale"]
    m.on_input(protocol.parse(json.dumps(msg(None))), 0.6)  # input keeps the link fresh, not the hands
    assert m.step(0.7)["tracked"].tolist() == [False, False] and not m.status(0.7)["stale"]
    _on_hands(m, 0.8, right=synthetic_hand([0.2, 1.2, -0.3]))
    m.disconnect(0.81)
    assert m.step(0.82)["tracked"].tolist() == [False, False]
    assert m.lost_count == 3
    m.connect(0.9)  # a new page: nothing is tracked until it sends hands
    assert not m.step(0.91)["tracked"].any()


def test_the_driving_hands_pinch_is_the_gripper_and_finish_is_done():
    m = _hand_mapper(hand="left")
    _on_hands(m, 0.0, left=synthetic_hand(pinch_m=0.015), right=synthetic_hand(pinch_m=0.08))
    assert m.step(0.0)["gripper"] == pytest.approx(0.0, abs=1e-3)  # the left hand pinches: closed
    _on_hands(m, 0.01, left=synthetic_hand(pinch_m=0.0475), right=synthetic_hand(pinch_m=0.015))
    assert m.step(0.01)["gripper"] == pytest.approx(0.5, abs=2e-3)
    s = m.step(1.0)  # stale: the gripper holds its last command
    assert not s["tracked"].any() and s["gripper"] == pytest.approx(0.5, abs=2e-3)
    m.on_input(protocol.parse(json.dumps(msg(None, done=True, mode=True))), 1.0)
    assert m.step(1.0)["buttons"].tolist() == [False, True]  # mode means nothing to a hand tracker
    assert m.step(1.01)["buttons"].tolist() == [False, True]  # latched: a loop reading 1 sample in 2 sees it
    m.restart()  # the node's reset(): a new run
    assert m.step(1.02)["buttons"].tolist() == [False, False]
    with pytest.raises(ValueError, match="left"):
        HandMapper(hand="both")


def test_the_hands_node_is_a_hand_tracker_with_the_contracts_sample(tmp_path):
    pytest.importorskip("aiohttp")
    from rio_teleop.webxr.node import WebXRHands, WebXRTeleop

    from rio.testing import lifecycle

    assert WebXRHands.hand_tracker and not WebXRTeleop.hand_tracker
    node = WebXRHands(port=0, cert_dir=str(tmp_path / "cert"), hand="left", yaw_deg=-90)
    node.setup()
    assert set(node.example_data) == {"twist", "gripper", "buttons", "wrist_pose", "hand_keypoints", "tracked"}
    with lifecycle(node):
        cfg = node.page_config()
        assert cfg["hands"] and cfg["hand"] == "left" and cfg["hands_hz"] == 60
        node.connected()
        node.message(protocol.parse(json.dumps(hands_message(left=synthetic_hand([0, 1, -0.5])))))
        s = node.read_state()
        assert s["tracked"].tolist() == [True, False]
        assert s["wrist_pose"][0, :3] == pytest.approx([0.0, -0.5, 1.0])  # forward, turned -90 deg: right
        assert {k: np.shape(v) for k, v in s.items()} == {k: np.shape(v) for k, v in node.example_data.items()}
        assert "teleop.webxr_hands" in node.help()
        node.reset()
        assert not node.read_state()["tracked"].any()
    with pytest.raises(ValueError, match="allow_remote"):
        WebXRHands.Config(host="0.0.0.0")


def test_webxr_hands_is_registered():
    from rio_teleop.webxr.specs import drivers

    spec = {s.name: s for s in drivers()}["teleop.webxr_hands"]
    assert spec.kind == "teleop" and spec.load().hand_tracker


def test_the_browser_tests_need_chromium_and_say_which_package(tmp_path, monkeypatch):
    browser = tmp_path / "chromium"
    monkeypatch.setenv("RIO_CHROMIUM", str(browser))
    assert CHROMIUM.missing() == ("needs Debian package chromium (apt install chromium) for the WebXR page in a real "
                                  f"headless browser: RIO_CHROMIUM={browser} does not exist")
    browser.write_text("")
    assert CHROMIUM.missing() is None
