"""teleop.webxr's server against a raw WebSocket client (no browser): hostile or broken messages are
refused without moving the arm, a silent stream makes it hold, and the page is only served to
others when asked. The arm is RIO's fake arm in `rio teleop`'s loop (run_teleop, thread middleware)."""

from __future__ import annotations

import asyncio
import json
import ssl
import time

import numpy as np
import pytest

pytest.importorskip("aiohttp")

from rio_teleop.webxr import harness  # noqa: E402
from rio_teleop.webxr.harness import input_message as msg  # noqa: E402

P0 = [0.0, 1.2, -0.3]


@pytest.fixture
def run(tmp_path):
    port = harness.free_port()
    station = harness.write_station(tmp_path, port=port, cert_dir=tmp_path / "cert")
    r = harness.TeleopRun(station, port=port, duration=60).start()
    yield r
    if r._thread.is_alive():
        harness.finish(r.port)
    r.join(20)


def _ctx() -> ssl.SSLContext:
    ctx = ssl.create_default_context()
    ctx.check_hostname, ctx.verify_mode = False, ssl.CERT_NONE
    return ctx


async def _session(port, body, headers=None):
    import aiohttp

    async with aiohttp.ClientSession() as s, s.ws_connect(f"wss://localhost:{port}/ws", ssl=_ctx(),
                                                         headers=headers or {}) as ws:
        assert json.loads(await ws.receive_str())["type"] == "config"
        return await body(ws)


async def _until(ws, kind, timeout=2.0):
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        m = json.loads(await asyncio.wait_for(ws.receive_str(), timeout))
        if m["type"] == kind:
            return m
    raise TimeoutError(kind)


async def _latest_status(ws, listen=0.3):
    """The newest status (statuses queue up at 10 Hz while the test is busy)."""
    last, t_end = None, time.monotonic() + listen
    while time.monotonic() < t_end or last is None:
        m = json.loads(await asyncio.wait_for(ws.receive_str(), 2.0))
        if m["type"] == "status":
            last = m
    return last


async def _closed(ws):
    """The close frame, skipping what came before it."""
    while True:
        m = await asyncio.wait_for(ws.receive(), 2.0)
        if m.type.name in ("CLOSE", "CLOSED", "CLOSING"):
            return m


async def _clutch(ws, p=P0):
    await ws.send_str(json.dumps(msg(p, clutch=False)))
    await asyncio.sleep(0.05)
    await ws.send_str(json.dumps(msg(p, clutch=True)))
    await asyncio.sleep(0.05)


def test_malformed_nan_and_huge_messages_are_refused_and_the_arm_stays(run):
    start = run.wait_still()

    async def hostile(ws):
        await _clutch(ws)  # engaged: anything that got through would move the arm
        bad = [
            '{"type": "input", "seq": 1, "t": 0, "source": "test", "pose": {"p": [NaN, 0, 0], "q": [0, 0, 0, 1]},'
            ' "clutch": true, "trigger": 0, "mode": false, "done": false}',
            json.dumps(msg([0.0, 1.2, -0.3], clutch=True)).replace("-0.3", "-1e999"),  # overflows to -inf
            json.dumps(msg([0.0, 1.2, -1e6], clutch=True)),  # finite but absurd
            json.dumps(msg([0.0, 1.2, -0.4], q=[0, 0, 0, 0], clutch=True)),  # not a rotation
            json.dumps({**msg([0.0, 1.2, -0.4], clutch=True), "trigger": "1"}),  # wrong type
            json.dumps({**msg([0.0, 1.2, -0.4], clutch=True), "extra": 1}),  # unknown key
            json.dumps({**msg([0.0, 1.2, -0.4], clutch=True), "clutch": 1}),  # not a bool
            json.dumps({"type": "shell", "cmd": "rm -rf /"}),
            "[1, 2, 3]", "not json", "{" * 500 + "}" * 500,
        ]
        errors = []
        for b in bad:
            await ws.send_str(b)
            errors.append(await _until(ws, "error"))
            await ws.send_str(json.dumps(msg(P0, clutch=True)))  # the valid stream goes on: still engaged
        status = await _latest_status(ws, listen=0.1)
        # a frame over the size limit closes the connection
        await ws.send_str(json.dumps({**msg(P0, clutch=True), "pad": "x" * 100_000}))
        closed = await _closed(ws)
        return errors, status, closed

    errors, status, closed = asyncio.run(_session(run.port, hostile))
    assert len(errors) == 11 and all(e["message"] for e in errors)
    assert status["rejected"] >= 11 and status["engaged"]  # refused, and the valid clutch still holds
    assert closed.type.name in ("CLOSE", "CLOSED") and closed.data == 1009  # message too big
    time.sleep(0.5)
    assert np.linalg.norm(run.eef()[:3] - start[:3]) < 1e-4, "a refused message moved the arm"


def test_binary_frames_and_a_foreign_origin_are_refused(run):
    import aiohttp

    async def binary(ws):
        await ws.send_bytes(b"\x00" * 16)
        return await _closed(ws)

    closed = asyncio.run(_session(run.port, binary))
    assert closed.data == 1003

    async def foreign():
        async with aiohttp.ClientSession() as s:
            with pytest.raises(aiohttp.WSServerHandshakeError) as e:
                await s.ws_connect(f"wss://localhost:{run.port}/ws", ssl=_ctx(), headers={"Origin": "https://evil.example"})
            return e.value.status

    assert asyncio.run(foreign()) == 403


def test_one_operator_at_a_time(run):
    import aiohttp

    async def two(ws):
        async with aiohttp.ClientSession() as s, s.ws_connect(f"wss://localhost:{run.port}/ws", ssl=_ctx()) as ws2:
            m = json.loads(await ws2.receive_str())
            closed = await _closed(ws2)
            return m, closed

    m, closed = asyncio.run(_session(run.port, two))
    assert m["type"] == "error" and "another operator" in m["message"] and closed.data == 4001


def test_a_silent_client_frees_the_operator_slot_and_a_pinging_page_keeps_it(tmp_path):
    """A client that connects and sends nothing held the one operator slot for as long as it stayed
    connected; now it is closed after `silence_s` and the next page gets the slot. A page that only pings
    (as the real page does every 0.5 s, outside an XR session too) keeps it past `silence_s`."""
    import aiohttp

    port = harness.free_port()
    station = harness.write_station(tmp_path, port=port, cert_dir=tmp_path / "cert", teleop_extra="silence_s = 1.5")
    r = harness.TeleopRun(station, port=port, duration=60).start()
    try:
        r.wait_still()

        async def silent_then_next():
            async with aiohttp.ClientSession() as s:
                async with s.ws_connect(f"wss://localhost:{port}/ws", ssl=_ctx()) as ws:
                    assert json.loads(await ws.receive_str())["type"] == "config"
                    t0 = time.monotonic()
                    while True:  # say nothing; statuses keep coming until the server closes
                        m = await asyncio.wait_for(ws.receive(), 30.0)
                        if m.type.name in ("CLOSE", "CLOSED", "CLOSING") or time.monotonic() - t0 > 15.0:
                            break
                    closed, waited = m, time.monotonic() - t0
                async with s.ws_connect(f"wss://localhost:{port}/ws", ssl=_ctx()) as ws2:
                    first = json.loads(await ws2.receive_str())
                    t0, pongs = time.monotonic(), 0
                    while time.monotonic() - t0 < 4.0:  # pings only, for well past silence_s
                        await ws2.send_str(json.dumps({"type": "ping", "id": pongs, "t": 0}))
                        await _until(ws2, "pong", timeout=10.0)
                        pongs += 1
                        await asyncio.sleep(0.25)
                    status = await _latest_status(ws2, listen=0.1)
                    return closed, waited, first, ws2.closed, status

        closed, waited, first, ws2_closed, status = asyncio.run(silent_then_next())
        assert closed.data == 4002, closed  # closed for silence, not by anything else
        assert waited >= 1.5 - 0.1, waited  # not before silence_s (monotonic vs the server's clock: a hair)
        assert first["type"] == "config"  # the slot was free: not "another operator is connected"
        assert not ws2_closed and status["type"] == "status"  # the pinging page kept it
    finally:
        if r._thread.is_alive():
            harness.finish(r.port)
        r.join(20)


def test_a_stream_that_goes_silent_makes_the_arm_hold(run):
    start = run.wait_still()

    async def silent(ws):
        await _clutch(ws)
        await ws.send_str(json.dumps(msg([0.0, 1.2, -0.6], clutch=True)))  # +0.3 m: 2 s of motion
        await asyncio.sleep(0.4)  # then nothing, with the socket still open
        return await _latest_status(ws, listen=1.0)

    status = asyncio.run(_session(run.port, silent))
    assert status["stale"] and not status["engaged"] and status["holds"] == 1
    stopped = run.wait_still()
    moved = stopped[0] - start[0]
    assert 0.01 < moved < 0.15, moved  # stopped within a stale period (0.25 s) of the last message
    time.sleep(0.5)
    assert np.linalg.norm(run.eef()[:3] - stopped[:3]) < 1e-4


def test_serving_beyond_loopback_needs_asking():
    from pydantic import ValidationError
    from rio_teleop.webxr.node import WebXRTeleop

    with pytest.raises(ValidationError, match="allow_remote"):
        WebXRTeleop.Config(host="0.0.0.0")
    with pytest.raises(ValidationError, match="allow_remote"):
        WebXRTeleop.Config(host="192.168.1.20")
    assert WebXRTeleop.Config(host="0.0.0.0", allow_remote=True).host == "0.0.0.0"
    assert WebXRTeleop.Config().host == "127.0.0.1"


def test_robot_feedback_reaches_the_status_panel(tmp_path):
    from rio_teleop.webxr.node import WebXRTeleop

    from rio.testing import lifecycle

    node = WebXRTeleop(port=0, cert_dir=str(tmp_path / "cert"))
    node.setup()
    with lifecycle(node):
        node.feedback({"eef": np.array([0.1, 0.2, 0.3]), "gripper": 0.04, "bad": object()})
        assert "https://localhost:" in node.help() and node.fingerprint in node.help()

        async def status(ws):
            return await _latest_status(ws)

        s = asyncio.run(_session(node.server.port, status))
    assert s["robot"] == {"eef": [0.1, 0.2, 0.3], "gripper": 0.04}


def test_hands_stream_checks_and_the_watchdog_over_the_socket(tmp_path):
    """teleop.webxr_hands: hands messages (over input's 2048-byte limit) reach what the node publishes;
    broken ones are answered and counted without touching it; a frame over 8 KiB closes the link and
    a closed link untracks the hands."""
    from rio.testing import wait_until

    right = harness.synthetic_hand([0.1, 1.2, -0.3], [0.1, 0.2, 0.3, float(np.sqrt(0.86))])
    good = json.dumps(harness.hands_message(right=right))
    assert len(good) > 1024

    with harness.serve_hands(tmp_path / "cert") as node:
        async def body(ws):
            await ws.send_str(good)
            assert await asyncio.to_thread(wait_until, lambda: node.get_state()["tracked"][1], 3.0)
            published = node.get_state()
            bad_hand = {**right, "j": right["j"][:24]}
            bad = [json.dumps(harness.hands_message(right=bad_hand)),
                   good.replace(str(right["j"][3][0]), "NaN", 1),
                   good.replace(str(right["j"][3][0]), "1e999", 1),
                   json.dumps({**harness.hands_message(right=right), "extra": 1}),
                   json.dumps(harness.hands_message(right={**right, "q": [0, 0, 0, 0.2]})),
                   json.dumps({**msg(P0), "source": "x" * 3000})]  # only hands may pass 2048 bytes
            errors = []
            for b in bad:
                await ws.send_str(b)
                errors.append((await _until(ws, "error"))["message"])
                await ws.send_str(good)  # the valid stream goes on
            for _ in range(20):  # the panel's status says which hands are tracked (statuses queue: a few)
                await ws.send_str(good)
                status = await _until(ws, "status")
                if status["hands"]["right"]:
                    break
            still = node.get_state()
            await ws.send_str(json.dumps({**harness.hands_message(right=right), "pad": "x" * 9000}))
            closed = await _closed(ws)
            return published, errors, status, still, closed

        published, errors, status, still, closed = asyncio.run(_session(node.page()["port"], body))
        assert published["tracked"].tolist() == [False, True]
        assert published["wrist_pose"][1, :3] == pytest.approx([0.3, -0.1, 1.2])
        assert published["hand_keypoints"][1, 3] == pytest.approx([-right["j"][3][2], -right["j"][3][0],
                                                                  right["j"][3][1]])
        assert len(errors) == 6 and "25 joints" in errors[0] and "over 2048 bytes" in errors[-1], errors
        assert status["rejected"] >= 6 and status["hands"] == {"left": False, "right": True}
        assert still["tracked"].tolist() == [False, True]
        assert np.array_equal(still["hand_keypoints"], published["hand_keypoints"])  # nothing refused got in
        assert closed.data == 1009  # message too big
        assert wait_until(lambda: not node.get_state()["tracked"].any(), 3.0)  # disconnected: untracked
