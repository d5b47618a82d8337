"""Across a link at camera rates: the two sides of `bench/multi_machine.py --scenario cameras|requests`, and
of the shaped-link test (rio-core/tests/test_link_shaped.py). Each side runs in its own network namespace
(`rio.machine.netns`); both read one monotonic clock (one kernel), so a frame's age on the reader's side is
exact: the time it entered the reader's mirror (decoded) minus its capture timestamp.

- cameras: 3 colour cameras (640x480 RGB) and 1 depth camera (640x480 uint16) at 30 fps, frames of a
  synthetic table-top scene (`SceneCamera`: they compress like real ones), served over zmq on
  the robot's address; `codec` "raw" (every byte crosses) or "auto" (JPEG colour, zstd depth: the
  server serves another machine). The reader reports per run: frame age p50/p99, frames dropped (sequence
  numbers skipped), frames received, decode CPU per frame; the orchestrator adds link utilisation (the
  interface's byte counter) and encode CPU per frame (the same encoder on the same frames, timed here).
- requests: four request-taking nodes on the robot, a 500 Hz loop on the workstation sending each of them
  one request per tick: tick lateness p50/p99, `send_request` time p50/p99, with credits (protocol 4: a
  local check and a send) and with each request waiting for its acknowledgement (what protocol 3 did).
"""

from __future__ import annotations

import json
import sys
import time
from typing import Any

import numpy as np
from pydantic import Field

from rio.fakes.sensors import FakeCamera

PORT = 7800
FPS = 30.0
W, H = 640, 480
#: Distinct frames each camera cycles through (made at start: a few seconds on a loaded machine).
SCENE_FRAMES = 8
#: How long the robot side waits for its nodes (a loaded 2-core machine is slow to start four).
READY_S = 300.0
CAMERAS = [("cam0", False), ("cam1", False), ("cam2", False), ("depth0", True)]
#: The shaped-link test's lighter set: one colour camera, one depth camera.
PAIR = [("cam0", False), ("depth0", True)]


class SceneCamera(FakeCamera):
    """A fake camera whose frames are a table-top-like scene (`rio.recording.synthetic`: texture, moving
    discs, noise; depth a slanted plane with a disc 10 cm closer), cycling through `scene` frames made at
    start: what compression figures need (the fake camera's flat frames compress to nothing)."""

    class Config(FakeCamera.Config):
        scene: int = Field(8, ge=1, le=300, description="distinct frames to cycle through")
        seed: int = Field(0, description="the scene's seed")

    def open(self) -> None:
        from rio.recording.synthetic import SyntheticCamera

        cam = SyntheticCamera(self.height, self.width, seed=self.config.seed)
        self.scene: list[tuple[np.ndarray, np.ndarray]] = []
        for i in range(self.config.scene):
            t = i / self.config.rate_hz
            rgb = cam.frame(t)
            depth = np.round(cam.depth(t) * 1000).astype(np.uint16)
            depth[(rgb == cam.colors[0]).all(-1)] -= 100
            self.scene.append((rgb, depth))

    def read_state(self) -> dict[str, Any]:
        out = super().read_state()
        out["rgb"], depth = self.scene[self.frame % len(self.scene)]
        if self.has_depth:
            out["depth"] = depth
        return out


def _cameras(which: str) -> list[tuple[str, bool]]:
    return PAIR if which == "pair" else CAMERAS
ECHOES = ["node0", "node1", "node2", "node3"]


def _mw() -> Any:
    from rio.middleware.zmq import ZmqMiddleware

    # Generous liveness: the figures are the link's, and a loaded machine may pause a reader for a while.
    return ZmqMiddleware(insecure=True, heartbeat_timeout=30.0, connect_timeout=60.0, station="bench")


def _placed(names: list[str], host: str, port: int) -> tuple[Any, dict[str, tuple[dict, dict]]]:
    from rio.station.model import MachineSection

    mw = _mw()
    section = MachineSection(address=host, nodes=names, port=port)
    return mw, {n: mw.placed(n, i, "robot", section) for i, n in enumerate(names)}


def camera_options(name: str, depth: bool, codec: str) -> dict[str, Any]:
    """The config of one bench camera: colour-only cameras publish no depth field."""
    return {"name": name, "rate_hz": FPS, "width": W, "height": H, "depth": depth, "scene": SCENE_FRAMES,
            "seed": sum(map(ord, name)), "codec": codec, "depth_codec": codec}


def serve_cameras(host: str, codec: str, port: int = PORT, which: str = "all") -> None:
    """Robot side: the cameras at their placed addresses until stdin closes."""
    from rio.runtime.manager import ServerManager, serve

    cams = _cameras(which)
    mw, placed = _placed([n for n, _ in cams], host, port)
    specs = [serve(SceneCamera, mw.with_options(**placed[n][0]), **camera_options(n, d, codec)) for n, d in cams]
    with ServerManager(specs, station="bench", ready_timeout=READY_S):
        print("ready", flush=True)
        sys.stdin.read()


def _rx_bytes(dev: str | None) -> int:
    if not dev:
        return 0
    with open(f"/sys/class/net/{dev}/statistics/rx_bytes") as f:
        return int(f.read())


def read_cameras(host: str, codec: str, seconds: float, port: int = PORT, dev: str | None = None,
                 which: str = "all") -> dict[str, Any]:
    """Workstation side: mirror the four cameras for `seconds`; ages, drops, decode cost, and the bytes
    received on interface `dev` meanwhile (one JSON line)."""
    from rio import clock
    from rio.runtime.manager import connect

    cams = _cameras(which)
    mw, placed = _placed([n for n, _ in cams], host, port)
    clients: dict[str, Any] = {}
    ages: dict[str, list[float]] = {n: [] for n, _ in cams}
    first_seq: dict[str, tuple[int, int]] = {}
    try:
        for n, d in cams:
            c = connect(SceneCamera, mw, station="bench", address=placed[n][1], **camera_options(n, d, codec))
            clients[n] = c
        time.sleep(1.0)  # connections settle; the frames before this are not counted
        for n, c in clients.items():
            t = c._transport
            first_seq[n] = (t._seq, t.ring_buffer.count)
            t.ring_buffer.on_put = (lambda rec, a=ages[n]: a.append(clock.now() - float(rec["timestamp"])))
        rx0, t0 = _rx_bytes(dev), time.monotonic()
        time.sleep(seconds)
        rx, took = _rx_bytes(dev) - rx0, time.monotonic() - t0
        out: dict[str, Any] = {"cameras": {}, "rx_mbit_s": round(rx * 8 / took / 1e6, 1)}
        for n, c in clients.items():
            t = c._transport
            t.ring_buffer.on_put = None
            seq0, count0 = first_seq[n]
            published, received = t._seq - seq0, t.ring_buffer.count - count0
            dec = t.decoder.stats if t.decoder is not None else None
            a = np.asarray(ages[n]) * 1e3
            out["cameras"][n] = {
                "received": int(received), "dropped": int(max(published - received, 0)),
                "age_p50_ms": round(float(np.percentile(a, 50)), 2) if a.size else None,
                "age_p99_ms": round(float(np.percentile(a, 99)), 2) if a.size else None,
                "decode_ms": round(dec.cpu_ms_per_frame, 2) if dec else 0.0,
                "bytes_per_frame": int(dec.coded_bytes / dec.frames) if dec and dec.frames else
                int(t.layouts.data.itemsize), **_fidelity(n, dict(cams)[n], codec, c.get_state())}
        return out
    finally:
        for c in clients.values():
            c.close()


def _fidelity(name: str, depth: bool, codec: str, got: dict[str, Any]) -> dict[str, Any]:
    """How the newest frame read compares with the frame the camera sent (its scene is deterministic):
    PSNR of the colour frame (dB, inf when exact), and whether the depth frame is exact."""

    opts = camera_options(name, depth, codec)
    cam = SceneCamera(**{k: v for k, v in opts.items() if k != "name"})
    cam.name = name
    cam.setup()
    cam.open()
    mse = min(float(np.mean((got["rgb"].astype(np.float64) - rgb) ** 2)) for rgb, _ in cam.scene)
    out: dict[str, Any] = {"rgb_psnr_db": round(10 * np.log10(255.0 ** 2 / mse), 1) if mse else float("inf")}
    if depth:
        out["depth_exact"] = any(np.array_equal(got["depth"], d) for _, d in cam.scene)
    return out


def encode_cost(codec: str, frames: int = 10) -> dict[str, float]:
    """CPU ms per frame the robot side spends encoding (the server's encoder, these frames, this machine)."""
    from rio.middleware.protocol.codecs import encoder_for
    from rio.runtime.layout import Layout

    out = {}
    for depth in (False, True):
        cam = SceneCamera(**{k: v for k, v in camera_options("cam", depth, codec).items() if k != "name"})
        cam.name = "cam"
        cam.setup()
        cam.open()
        layout = Layout(cam.example_data, owner="cam")
        enc = encoder_for(cam, layout, linked=True)
        if enc is None:
            out["depth" if depth else "rgb"] = 0.0
            continue
        for i in range(frames):
            enc.encode(layout.encode(cam.read_state(), fill_timestamp=float(i)))
        out["depth" if depth else "rgb"] = round(enc.stats.cpu_ms_per_frame, 2)
    return out


def serve_echoes(host: str, port: int = PORT + 50) -> None:
    from rio.runtime.manager import ServerManager, serve
    from rio.testing import EchoNode

    mw, placed = _placed(ECHOES, host, port)
    with ServerManager([serve(EchoNode, mw.with_options(**placed[n][0]), name=n, rate_hz=500) for n in ECHOES],
                       station="bench", ready_timeout=READY_S):
        print("ready", flush=True)
        sys.stdin.read()


def request_loop(host: str, seconds: float, acknowledged: bool, rate_hz: float = 500.0,
                 port: int = PORT + 50) -> dict[str, Any]:
    """Workstation side: a `rate_hz` loop sending each of the four nodes one request per tick."""
    from rio import clock
    from rio.errors import QueueFull
    from rio.runtime.manager import connect
    from rio.testing import EchoNode

    mw, placed = _placed(ECHOES, host, port)
    clients = [connect(EchoNode, mw, name=n, station="bench", address=placed[n][1]) for n in ECHOES]
    try:
        layout = clients[0]._transport.request_queue.layout  # type: ignore[attr-defined]
        late: list[float] = []
        took: list[float] = []
        refused = overruns = 0
        period = 1.0 / rate_hz
        n_ticks = int(seconds * rate_hz)
        t_next = t_start = clock.now() + 0.1
        for i in range(n_ticks):
            clock.precise_wait(t_next)
            t0 = clock.now()
            late.append(t0 - t_next)
            for c in clients:
                t1 = clock.now()
                try:
                    if acknowledged:
                        rec = layout.encode({"q": np.full(6, float(i)), "client": 1, "seq": i}, fill_timestamp=t1)
                        c._transport.send_request_acknowledged(rec.tobytes())  # type: ignore[attr-defined]
                    else:
                        c.send_request(q=np.full(6, float(i)), client=1, seq=i)
                except QueueFull:
                    refused += 1
                took.append(clock.now() - t1)
            t_next += period
            if clock.now() > t_next:  # an overrun: the tick's sends ran past the next deadline; re-anchor
                overruns += 1
                t_next = clock.now()
        elapsed = clock.now() - t_start
        stats = [c._transport.request_stats(wait_s=2.0) for c in clients]  # type: ignore[attr-defined]
        lt, tk = np.asarray(late) * 1e3, np.asarray(took) * 1e6
        return {"mode": "acknowledged" if acknowledged else "credits", "ticks": n_ticks,
                "achieved_hz": round(n_ticks / elapsed, 1), "overruns": overruns,
                "late_p50_ms": round(float(np.percentile(lt, 50)), 3),
                "late_p99_ms": round(float(np.percentile(lt, 99)), 3),
                "send_p50_us": round(float(np.percentile(tk, 50)), 1),
                "send_p99_us": round(float(np.percentile(tk, 99)), 1),
                "no_credits": int(sum(s.no_credits for s in stats)), "refused": int(sum(s.refused for s in stats)),
                "queue_full_raised": refused, "sent": int(sum(s.sent for s in stats))}
    finally:
        for c in clients:
            c.close()


def main(argv: list[str]) -> int:
    """`python -m rio.benchmarks.link serve-cameras HOST CODEC [all|pair]` |
    `read-cameras HOST CODEC SECONDS [DEV|-] [all|pair]` |
    `serve-echoes HOST` | `request-loop HOST SECONDS credits|acknowledged`."""
    what, host = argv[0], argv[1]
    if what == "serve-cameras":
        serve_cameras(host, argv[2], which=argv[3] if len(argv) > 3 else "all")
    elif what == "read-cameras":
        dev = argv[4] if len(argv) > 4 and argv[4] != "-" else None
        which = argv[5] if len(argv) > 5 else "all"
        print(json.dumps(read_cameras(host, argv[2], float(argv[3]), dev=dev, which=which)), flush=True)
    elif what == "serve-echoes":
        serve_echoes(host)
    elif what == "request-loop":
        print(json.dumps(request_loop(host, float(argv[2]), argv[3] == "acknowledged")), flush=True)
    else:
        raise SystemExit(f"unknown side {what!r}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
