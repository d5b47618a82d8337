"""Small nodes for tests, benchmarks and plugin authors' own test suites.

They live in an importable module (not in test files) because process middlewares spawn a fresh
interpreter that must import the node class by name.
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np

from .node import Node


class EchoNode(Node):
    """Publishes a counter and the last request; `echo` returns its argument (latency benchmarks)."""

    __api__ = ("get_state", "send_request", "echo", "fail", "pid", "handled", "sleep")

    def __init__(self, payload_bytes: int = 2048, rate_hz: float = 200.0, n: int = 6):
        super().__init__(rate_hz=rate_hz)
        self.payload_bytes, self.n = payload_bytes, n
        self.example_data = {"tick": 0, "q": np.zeros(n), "last": np.zeros(n)}
        self.example_request = {"q": np.zeros(n), "client": 0, "seq": 0}
        self.tick = 0
        self.last = np.zeros(n)
        self.received: list[tuple[int, int]] = []

    def read_state(self) -> dict[str, Any]:
        self.tick += 1
        return {"tick": self.tick, "q": np.full(self.n, float(self.tick)), "last": self.last}

    def handle_request(self, request: dict[str, Any]) -> None:
        self.last = np.asarray(request["q"]).copy()
        self.received.append((int(request["client"]), int(request["seq"])))

    def echo(self, payload: Any) -> Any:
        return payload

    def fail(self, message: str) -> None:
        raise ValueError(message)

    def pid(self) -> int:
        return os.getpid()

    def handled(self) -> list[list[int]]:
        """Every (client, seq) request handled so far, in order."""
        return [list(x) for x in self.received]

    def sleep(self, seconds: float) -> float:
        time.sleep(seconds)
        return seconds


class ImageNode(Node):
    """Publishes HxWx3 uint8 frames as fast as its rate allows (image-streaming benchmark)."""

    __api__ = ("get_state",)

    def __init__(self, height: int = 480, width: int = 640, rate_hz: float = 30.0):
        super().__init__(rate_hz=rate_hz)
        self.example_data = {"rgb": np.zeros((height, width, 3), np.uint8), "frame": 0}
        self._frames = [np.full((height, width, 3), i, np.uint8) for i in range(4)]
        self.frame = 0

    def read_state(self) -> dict[str, Any]:
        self.frame += 1
        return {"rgb": self._frames[self.frame % 4], "frame": self.frame}


class FailingOpenNode(Node):
    """Raises in open(): start-up errors must reach ServerManager with the node's name."""

    __api__ = ("get_state",)

    def __init__(self) -> None:
        super().__init__()
        self.example_data = {"x": 0.0}

    def open(self) -> None:
        raise RuntimeError("device /dev/ttyFAKE not found")
