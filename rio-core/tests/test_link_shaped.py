"""Cameras across a shaped link, emulated on one machine: a colour and a depth camera (640x480, 30 fps)
served over zmq in the robot's network namespace, read in the workstation's, over a veth shaped with `tc`
to 100 Mbit/s (with netem: 2 ms, 0.1 % loss). With the default codecs (auto: the node serves another
machine) frames arrive compressed and are decoded on the reader's side: the depth frame exact, the colour
frame close (PSNR), frames keep arriving. Needs Linux, root and `tc` (CI has them); skipped otherwise."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from rio.machine import netns

pytest.importorskip("cv2")
pytest.importorskip("zstandard")


@pytest.fixture(scope="module")
def net():
    why = netns.available() or netns.TC.missing()
    if why:
        pytest.skip(f"the shaped-link test needs two network namespaces and tc: {why}")
    with netns.TwoMachines() as n:
        yield n


def _side(side, *args: str) -> subprocess.Popen:
    return side.popen([sys.executable, "-m", "rio.benchmarks.link", *args], stdin=subprocess.PIPE,
                      stdout=subprocess.PIPE, text=True)


def test_cameras_cross_a_100_mbit_link_compressed_and_decoded(net):
    applied = net.shape("100mbit", 2.0, 0.1)
    srv = _side(net.a, "serve-cameras", net.a.address, "auto", "pair")
    try:
        assert srv.stdout.readline().strip() == "ready", f"cameras did not start (exit code {srv.poll()})"
        out = net.b.run([sys.executable, "-m", "rio.benchmarks.link", "read-cameras", net.a.address, "auto", "3",
                         net.b.dev, "pair"], capture_output=True, text=True, timeout=300)
        assert out.returncode == 0, out.stderr[-3000:]
        got = json.loads(out.stdout.strip().splitlines()[-1])
    finally:
        srv.stdin.close()
        try:
            srv.wait(timeout=30)
        except subprocess.TimeoutExpired:
            srv.kill()
        net.shape()
    cam, depth = got["cameras"]["cam0"], got["cameras"]["depth0"]
    raw_rgb, raw_depth = 640 * 480 * 3, 640 * 480 * (3 + 2)
    assert cam["received"] >= 10 and depth["received"] >= 10, (applied, got)  # ~90 each in 3 s at 30 fps
    assert cam["bytes_per_frame"] < raw_rgb / 4, got  # JPEG crossed the link, not raw pixels
    assert depth["bytes_per_frame"] < raw_depth / 2, got
    assert depth["depth_exact"], "depth decoded on the reader's side is not the camera's frame (lossless)"
    assert cam["rgb_psnr_db"] > 30.0, got
    assert cam["decode_ms"] > 0 and depth["decode_ms"] > 0, got  # decoded here, once per frame
    assert 0 < cam["age_p50_ms"] < 2000, got  # capture times came through unchanged: ages are sane
