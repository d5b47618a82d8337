"""`cameras.stream` on a network stream through the REAL OpenCV FFMPEG backend: a small HTTP MJPEG server
(multipart/x-mixed-replace, as IP webcams and mjpg-streamer serve) runs on 127.0.0.1 in this process. The
tests check the frames (RGB order), and that a stream cut off mid-run is reported by name, retried while
the server refuses, and reopened when it serves again, with the node up throughout."""

from __future__ import annotations

import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import cv2
import numpy as np
import pytest
from rio_cameras.stream.driver import StreamCamera

from rio.testing import lifecycle, wait_until


class MjpegServer:
    """Serves a 64x48 JPEG (left half red, right half blue) as an endless MJPEG stream at ~30 fps on
    127.0.0.1. `cut()` ends the streams in progress and answers 503 until `resume()`."""

    def __init__(self):
        rgb = np.zeros((48, 64, 3), np.uint8)
        rgb[:, :32] = (255, 0, 0)
        rgb[:, 32:] = (0, 0, 255)
        jpeg = cv2.imencode(".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))[1].tobytes()
        part = b"--frame\r\nContent-Type: image/jpeg\r\nContent-Length: %d\r\n\r\n" % len(jpeg) + jpeg + b"\r\n"
        self.serving, self.closed = threading.Event(), threading.Event()
        self.serving.set()
        server = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args):
                pass

            def do_GET(self):  # noqa: N802 - http.server's spelling
                if not server.serving.is_set():
                    self.send_error(503)
                    return
                self.send_response(200)
                self.send_header("Content-Type", "multipart/x-mixed-replace; boundary=frame")
                self.end_headers()
                try:
                    while server.serving.is_set() and not server.closed.is_set():
                        self.wfile.write(part)
                        time.sleep(1 / 30)
                except OSError:  # the client went away
                    pass

        self.http = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.http.daemon_threads = True
        self.url = f"http://127.0.0.1:{self.http.server_address[1]}/video.mjpg"
        self.thread = threading.Thread(target=self.http.serve_forever, daemon=True)
        self.thread.start()

    def cut(self):
        self.serving.clear()

    def resume(self):
        self.serving.set()

    def close(self):
        self.closed.set()
        self.http.shutdown()
        self.http.server_close()


@pytest.fixture
def server():
    s = MjpegServer()
    yield s
    s.close()


def next_sample(node, timeout: float = 10.0) -> dict:
    seen: list = []
    assert wait_until(lambda: seen.append(node.read_state()) or seen[-1] is not None, timeout=timeout)
    return seen[-1]


def test_mjpeg_over_http_through_ffmpeg(server):
    with lifecycle(StreamCamera(url=server.url, width=64, height=48, timeout_s=5)) as cam:
        rgb = next_sample(cam)["rgb"]
        info = cam.camera_info()
    assert info["source"] == "network" and "FFMPEG" in info["delivered"]
    assert np.abs(rgb[8:40, 4:28].astype(int) - (255, 0, 0)).max() < 24
    assert np.abs(rgb[8:40, 36:60].astype(int) - (0, 0, 255)).max() < 24


def test_a_dropped_stream_is_named_retried_and_reopened(server):
    with lifecycle(StreamCamera(url=server.url, width=64, height=48, timeout_s=2, reopen_s=0.2)) as cam:
        next_sample(cam)
        server.cut()
        assert wait_until(lambda: "reopen failed" in (cam.camera_info()["error"] or ""), timeout=20)
        assert cam.camera_info()["lost"] == 1 and "could not open it" in cam.camera_info()["error"]
        server.resume()
        assert wait_until(lambda: cam.camera_info()["reopened"] == 1, timeout=20)
        next_sample(cam)
        assert cam.camera_info()["error"] is None
