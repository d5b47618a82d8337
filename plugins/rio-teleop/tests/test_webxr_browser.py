"""teleop.webxr end to end in real headless Chromium: the page is loaded from the node's HTTPS server,
synthetic poses go in through `window.__rioInjectPose` (the function WebXR frames call, so the same
message path), and RIO's fake arm is driven by `rio teleop`'s loop (`run_teleop`, thread middleware).

Poses are in WebXR's frame (y up, -z forward, x right); the robot's base is x forward, y left, z up:
controller -z -> tool +x, controller -x -> tool +y, controller +y -> tool +z.

`teleop.webxr_hands`: synthetic hands go in through `window.__rioInjectHands` (the function XR frames
with hand tracking call) and the node, served alone, publishes them as the hand tracker contract.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from rio.testing import skip_tests_without

skip_tests_without("playwright")  # found, not imported (0.3 s in every test process that collects this file)
skip_tests_without("aiohttp")

from rio_teleop.webxr import harness  # noqa: E402

P0 = np.array([0.1, 1.2, -0.3])  # where the controller starts (meters, WebXR local-floor)
TOL = 0.003
#: How long a wait for something the page or the node does in milliseconds may take: a headless browser beside
#: a loaded suite (load 13-14) once took more than 5 s to engage. A wait that succeeds returns at once.
WAIT_S = 15.0


def _xr(robot_dx=0.0, robot_dy=0.0, robot_dz=0.0) -> list[float]:
    """The controller position that moves the tool by (dx, dy, dz) from P0 (scale 1)."""
    return list(P0 + np.array([-robot_dy, robot_dz, -robot_dx]))


@pytest.fixture(scope="module")
def browser():
    from playwright.sync_api import Error, sync_playwright

    skip_tests_without(harness.CHROMIUM)
    skip_tests_without(harness.PLAYWRIGHT_DRIVER)  # else sync_playwright() fails: "Connection closed while reading"
    with sync_playwright() as pw:
        try:
            b = harness.launch_chromium(pw)
        except Error as e:
            pytest.skip(f"Chromium cannot start here: {str(e).splitlines()[0]}")
        yield b
        b.close()


@pytest.fixture
def run(tmp_path):
    port = harness.free_port()
    station = harness.write_station(tmp_path, port=port, cert_dir=tmp_path / "cert")
    r = harness.TeleopRun(station, port=port, duration=60).start()
    r.contexts = []
    yield r
    for ctx in r.contexts:  # a failed test leaves its page open: close it so Finish is not 'busy'
        ctx.close()
    if r._thread.is_alive():
        harness.finish(r.port)
    r.join(20)


def _open(browser, run):
    return harness.open_page(browser, run.url, run.contexts)


def _pose(page, p, clutch, trigger=0.0):
    page.evaluate("([p, c, g]) => window.__rioInjectPose(p, [0, 0, 0, 1], {clutch: c, trigger: g})",
                  [list(map(float, p)), clutch, trigger])


def _press_clutch(page, p):
    _pose(page, p, False)
    time.sleep(0.1)
    _pose(page, p, True)
    page.wait_for_function("window.__rioState().status && window.__rioState().status.engaged", timeout=WAIT_S * 1000)


def _near(target):
    return lambda pose: np.linalg.norm(pose[:3] - target) < TOL


def test_the_page_is_served_over_https_and_the_arm_follows_the_controller_to_its_target(browser, run):
    ctx, page = _open(browser, run)
    assert page.url.startswith("https://") and "rio teleop" in page.title()
    start = run.eef()[:3]
    _press_clutch(page, _xr())
    target = start + [0.08, 0.02, 0.03]
    _pose(page, _xr(0.08, 0.02, 0.03), True, trigger=1.0)  # trigger pulled: gripper closes
    run.wait_for(_near(target), timeout=WAIT_S)
    end = run.wait_still()
    assert np.linalg.norm(end[:3] - target) < TOL, (end[:3], target)
    status = page.evaluate("window.__rioState().status")
    assert status["engaged"] and not status["stale"] and status["rejected"] == 0
    assert page.evaluate("window.__rioState().rtt") is not None  # the panel's round trip
    state = page.evaluate("window.__rioState()")
    assert state["config"]["hands"] is False and state["handsSent"] == 0  # teleop.webxr: no hands streamed
    page.click("#done")  # the page's Finish button ends `rio teleop`
    summary = run.join(20)
    ctx.close()
    assert summary.reason == "the device finished"
    assert summary.arms[0].gripper == pytest.approx(0.0, abs=1e-3)  # closed by the trigger


def test_releasing_the_clutch_reanchors(browser, run):
    ctx, page = _open(browser, run)
    start = run.eef()[:3]
    _press_clutch(page, _xr())
    _pose(page, _xr(0.05), True)
    run.wait_for(_near(start + [0.05, 0, 0]), timeout=WAIT_S)
    held = run.wait_still()
    # released: the controller goes back (and further) without the arm
    _pose(page, _xr(0.05), False)
    for dx in np.linspace(0.05, -0.06, 12):
        _pose(page, _xr(dx, 0.03), False)
        time.sleep(0.03)
    time.sleep(0.5)
    assert np.linalg.norm(run.eef()[:3] - held[:3]) < 5e-4, "the arm moved while the clutch was up"
    # pressed again where the controller is now: the arm continues from where it is
    _press_clutch(page, _xr(-0.06, 0.03))
    _pose(page, _xr(-0.06 + 0.03, 0.03 - 0.02), True)
    target = held[:3] + [0.03, -0.02, 0.0]
    run.wait_for(_near(target), timeout=WAIT_S)
    assert np.linalg.norm(run.wait_still()[:3] - target) < TOL
    ctx.close()


def test_closing_the_page_holds_the_arm(browser, run):
    ctx, page = _open(browser, run)
    start = run.eef()[:3]
    _press_clutch(page, _xr())
    _pose(page, _xr(0.3), True)  # a long move (2 s at 0.15 m/s) ...
    run.wait_for(lambda pose: pose[0] - start[0] > 0.02, timeout=WAIT_S)
    ctx.close()  # ... cut short: the page goes away mid-move
    stopped = run.wait_still(timeout=3)
    assert 0.02 < stopped[0] - start[0] < 0.12, stopped[:3]  # stopped soon after, far from 0.3
    time.sleep(1.0)
    assert np.linalg.norm(run.eef()[:3] - stopped[:3]) < 5e-4, "the arm moved after the page closed"
    # a new page: the unfinished move is gone; pressing the clutch takes a new anchor, so no jump
    ctx, page = _open(browser, run)
    _press_clutch(page, _xr(0.1))
    time.sleep(0.6)
    assert np.linalg.norm(run.eef()[:3] - stopped[:3]) < 5e-4, "the arm jumped when the clutch was pressed again"
    _pose(page, _xr(0.12), True)
    run.wait_for(_near(stopped[:3] + [0.02, 0, 0]), timeout=WAIT_S)
    status = page.evaluate("window.__rioState().status")
    assert status["engaged"] and status["holds"] >= 1  # the watchdog took over once


# -- teleop.webxr_hands --------------------------------------------------------------------------------
def _robot(xr_points) -> np.ndarray:
    """WebXR (x right, y up, z back) -> robot (x forward, y left, z up), yaw 0."""
    p = np.asarray(xr_points, dtype=np.float64)
    return np.stack([-p[..., 2], -p[..., 0], p[..., 1]], axis=-1)


def _inject(page, left, right):
    page.evaluate("([l, r]) => { window.__rioInjectHands(l, r); }", [left, right])


def _until(pred, timeout=WAIT_S, what="the node's state"):
    from rio.testing import wait_until

    assert wait_until(pred, timeout), f"{what} did not come within {timeout:g} s"


@pytest.fixture
def hands(tmp_path):
    with harness.serve_hands(tmp_path / "cert") as node:
        contexts: list = []
        yield node, contexts
        for ctx in contexts:
            ctx.close()


def test_the_page_streams_both_hands_and_the_node_publishes_them(browser, hands):
    from rio_teleop.webxr.mapping import XR_TO_ROBOT

    from rio.control.rotations import matrix_to_quat, quat_angle, quat_mul, quat_normalize

    node, contexts = hands
    ctx, page = harness.open_page(browser, node.page()["url"], contexts)
    cfg = page.evaluate("window.__rioState().config")
    assert cfg["hands"] and cfg["hands_hz"] == 60
    assert not page.is_visible("#clutch") and page.is_visible("#done")  # no clutch with hands
    a = 0.5
    q_left = [0.0, float(np.sin(a / 2)), 0.0, float(np.cos(a / 2))]  # turned about XR up
    left = harness.synthetic_hand([-0.15, 1.1, -0.35], q_left, pinch_m=0.07)
    right = harness.synthetic_hand([0.123456, 1.25, -0.4], pinch_m=0.02)
    _inject(page, left, right)
    _until(lambda: node.get_state()["tracked"].all(), what="both hands tracked")
    s = node.get_state()
    tol = 1.5e-4  # the page rounds positions to 0.1 mm
    assert s["hand_keypoints"][0] == pytest.approx(_robot(left["j"]), abs=tol)
    assert s["hand_keypoints"][1] == pytest.approx(_robot(right["j"]), abs=tol)
    assert s["wrist_pose"][:, :3] == pytest.approx(_robot([left["j"][0], right["j"][0]]), abs=tol)
    q_R = matrix_to_quat(XR_TO_ROBOT)
    want_left = quat_normalize(quat_mul(q_R, [q_left[3], *q_left[:3]]))
    assert quat_angle(s["wrist_pose"][0, 3:], want_left) < 1e-3
    assert quat_angle(s["wrist_pose"][1, 3:], q_R) < 1e-3
    assert s["gripper"] == pytest.approx((0.02 - 0.015) / 0.065, abs=0.01)  # the right hand's pinch
    assert np.abs(s["twist"]).max() == 0
    # the status panel says which hands are tracked
    page.wait_for_function("(() => { const h = window.__rioState().status && window.__rioState().status.hands;"
                           " return h && h.left && h.right; })()", timeout=WAIT_S * 1000)
    assert "left tracked" in page.text_content("#s-clutch")

    # the right hand moves 5 cm forward (XR -z): the node follows
    moved = harness.synthetic_hand([0.123456, 1.25, -0.45], pinch_m=0.08)
    _inject(page, left, moved)
    _until(lambda: abs(node.get_state()["wrist_pose"][1, 0] - 0.45) < tol, what="the moved wrist")
    _until(lambda: node.get_state()["gripper"] > 0.99, what="the released pinch")
    # the left hand is lost (null): untracked at once, the right one still is
    _inject(page, None, moved)
    _until(lambda: node.get_state()["tracked"].tolist() == [False, True], what="the left hand lost")
    time.sleep(0.6)  # the page keeps the injected hands fresh (like a held pose): still tracked
    assert node.get_state()["tracked"].tolist() == [False, True]
    assert page.evaluate("window.__rioState().handsSent") > 5

    # Finish is the done button
    page.click("#done")
    _until(lambda: node.get_state(k=50)["buttons"][:, 1].any(), what="done")

    # closing the page: nothing is tracked
    ctx.close()
    _until(lambda: not node.get_state()["tracked"].any(), what="untracked after the page closed")


# A stand-in for an XRFrame with hand tracking: each joint's pose is a column-major 4x4 matrix (what
# fillPoses writes), the wrist's orientation from getJointPose. `spec`: per handedness, the joints'
# positions by name, or null for a hand whose joints are not tracked now; `fill`: whether fillPoses
# exists; `names`: HAND_JOINTS.
_FAKE_FRAME = """([spec, q, fill, names]) => {
  const spaces = (side) => (spec[side] ? new Map(Object.keys(spec[side]).map((n) => [n, {side, name: n}]))
    : new Map(names.map((n) => [n, {side, name: n, lost: true}])));  // a hand whose joints are not tracked now
  const sources = [...Object.keys(spec).map((side) => ({handedness: side, hand: spaces(side)})),
    {handedness: 'none', gripSpace: {}}];  // and a controller-like source without a hand
  const pose = (sp) => (sp.lost ? null : {transform: {position: {x: spec[sp.side][sp.name][0],
    y: spec[sp.side][sp.name][1], z: spec[sp.side][sp.name][2]}, orientation: {x: q[0], y: q[1], z: q[2], w: q[3]}}});
  const frame = {session: {inputSources: sources}, getJointPose: (sp, ref) => pose(sp)};
  if (fill) frame.fillPoses = (sps, ref, out) => {
    sps.forEach((sp, i) => { const p = pose(sp); out.fill(0, 16 * i, 16 * i + 16);
      if (p) { out[16 * i + 12] = p.transform.position.x; out[16 * i + 13] = p.transform.position.y;
               out[16 * i + 14] = p.transform.position.z; out[16 * i + 15] = 1; } });
    return sps.every((sp) => !sp.lost);
  };
  return window.__rioXRHands(frame, {});
}"""


@pytest.mark.parametrize("fill", [True, False], ids=["fillPoses", "getJointPose"])
def test_an_xr_frames_hands_are_read_in_xrhand_order(browser, hands, fill):
    from rio.interfaces.teleop import HAND_JOINTS

    node, contexts = hands
    _, page = harness.open_page(browser, node.page()["url"], contexts)
    right = harness.synthetic_hand([0.1, 1.2, -0.3], pinch_m=0.03)
    by_name = {n: p for n, p in zip(HAND_JOINTS, right["j"], strict=True)}
    shuffled = dict(reversed(list(by_name.items())))  # the page asks for each joint by name
    q = [0.0, 0.6, 0.0, 0.8]
    got = page.evaluate(_FAKE_FRAME, [{"right": shuffled, "left": None}, q, fill, list(HAND_JOINTS)])
    assert got["left"] is None
    assert np.asarray(got["right"]["j"]) == pytest.approx(np.asarray(right["j"]), abs=1e-6)  # float32 with fill
    assert got["right"]["q"] == pytest.approx(q)
    missing = dict(list(by_name.items())[:24])  # a runtime without the 25th joint: that hand is not sent
    got = page.evaluate(_FAKE_FRAME, [{"right": missing}, q, fill, list(HAND_JOINTS)])
    assert got["right"] is None and got["left"] is None


def test_the_page_never_sends_a_hand_the_node_would_refuse(browser, hands):
    node, contexts = hands
    _, page = harness.open_page(browser, node.page()["url"], contexts)
    good = harness.synthetic_hand([0.1, 1.2, -0.3])
    far = {**good, "j": [*good["j"][:24], [0.1, 1.2, -1.3]]}  # a glitch: a fingertip 1 m from the wrist
    _inject(page, far, good)
    _until(lambda: node.get_state()["tracked"].tolist() == [False, True], what="the right hand alone")
    page.evaluate("([h]) => { h.j[3][1] = NaN; window.__rioInjectHands(h, null); }", [good])
    _until(lambda: not node.get_state()["tracked"].any(), what="neither hand")
    page.wait_for_function("window.__rioState().status && window.__rioState().status.hands", timeout=WAIT_S * 1000)
    time.sleep(0.3)
    assert page.evaluate("window.__rioState().status.rejected") == 0


def test_rio_teleop_moves_the_arm_with_the_streamed_wrist(browser, tmp_path):
    """The whole chain: the page's hands -> teleop.webxr_hands -> `rio teleop`'s hand retargeting
    (rio.teleop.hands) -> RIO's fake arm, which moves as the wrist moved since it was acquired."""
    pytest.importorskip("rio.teleop.hands")
    port = harness.free_port()
    station = harness.write_station(tmp_path, port=port, cert_dir=tmp_path / "cert", driver="teleop.webxr_hands")
    run = harness.TeleopRun(station, port=port, duration=60).start()
    contexts: list = []
    try:
        _, page = harness.open_page(browser, run.url, contexts)
        start = run.wait_still()
        _inject(page, None, harness.synthetic_hand([0.1, 1.2, -0.3], pinch_m=0.08))  # acquired: the anchor
        time.sleep(0.5)
        assert np.linalg.norm(run.eef()[:3] - start[:3]) < 5e-4, "the arm jumped when the hand was acquired"
        _inject(page, None, harness.synthetic_hand([0.1, 1.23, -0.35], pinch_m=0.08))  # 5 cm forward, 3 cm up
        target = start[:3] + [0.05, 0.0, 0.03]
        run.wait_for(_near(target), timeout=WAIT_S)
        assert np.linalg.norm(run.wait_still()[:3] - target) < TOL
        page.click("#done")
        run.join(20)
    finally:
        for ctx in contexts:
            ctx.close()
        if run._thread.is_alive():
            harness.finish(run.port)
            run.join(20)
