"""Errors a user of RIO can act on. Each names the node (and field) it is about."""

from __future__ import annotations

import os


class RioError(Exception):
    """Base class of every RIO error."""


class InvalidRequest(RioError, ValueError):
    """A request or sample does not match the node's declared example (key, shape, dtype, NaN/inf)."""

    def __init__(self, node: str, field: str | None, problem: str):
        self.node, self.field, self.problem = node, field, problem
        where = f"field '{field}'" if field else "request"
        super().__init__(f"node '{node}': {where}: {problem}")


class NodeError(RioError):
    """An exception raised inside a node, carried to the client that called it."""

    def __init__(self, node: str, exc_type: str, message: str, remote_traceback: str = ""):
        self.node, self.exc_type, self.message = node, exc_type, message
        self.remote_traceback = remote_traceback
        super().__init__(f"node '{node}' raised {exc_type}: {message}")

    def __str__(self) -> str:
        base = super().__str__()
        if self.remote_traceback:
            return f"{base}\n--- traceback inside node '{self.node}' ---\n{self.remote_traceback.rstrip()}"
        return base


class NodeDiedError(RioError):
    """The server side of a node is gone (process exited or stopped answering)."""

    def __init__(self, node: str, detail: str = ""):
        self.node, self.detail = node, detail
        super().__init__(f"node '{node}' is not running" + (f": {detail}" if detail else ""))


class NodeTimeout(RioError, TimeoutError):
    """A node did not answer within the allotted time while still apparently alive."""

    def __init__(self, node: str, what: str, timeout: float):
        self.node = node
        super().__init__(f"node '{node}': {what} timed out after {timeout:.3g} s")


class QueueFull(RioError):
    """A request queue stayed full for longer than the put timeout: the node is not keeping up."""

    def __init__(self, node: str, capacity: int, timeout: float):
        self.node = node
        super().__init__(
            f"node '{node}': request queue full ({capacity} slots) for {timeout:.3g} s; "
            "the node is not consuming requests (raise its rate or request_capacity)"
        )


class NoCredits(QueueFull):
    """`send_request` on a network middleware found no credit left: the node has acknowledged none of this
    client's last `credits` requests, so this one was not sent (nothing waits on the network). A control
    loop skips the node's command this cycle and counts it (the next command supersedes it)."""

    def __init__(self, node: str, credits: int, oldest_s: float):
        self.node, self.credits, self.oldest_s = node, credits, oldest_s
        RioError.__init__(self, f"node '{node}': request queue full for this client, request not sent: all "
                                f"{credits} of its request credits are in flight (the oldest unacknowledged for "
                                f"{oldest_s * 1e3:.3g} ms); the node or the link is not keeping up (lower the "
                                "command rate, or raise max_pending_per_peer)")


class ConfigError(RioError, ValueError):
    """A station file, plugin spec or middleware option is wrong; the message names where."""


class FrameGone(RioError):
    """A camera frame taken by reference (its timestamp) is no longer in its camera node's ring buffer:
    the camera overwrote it (a ring of N frames keeps N-1)."""

    def __init__(self, camera: str, timestamp: float, capacity: int, hint: str = ""):
        self.camera, self.timestamp = camera, timestamp
        super().__init__(f"camera '{camera}': frame {timestamp:.6f} is no longer in its ring buffer (the camera "
                         f"overwrote it; the ring keeps {capacity - 1} frames)" + (f"; {hint}" if hint else ""))


def debug() -> bool:
    """`rio --debug`, or RIO_DEBUG=1 in the environment (node processes inherit it): show the full
    traceback of every error, a RioError's too."""
    return os.environ.get("RIO_DEBUG", "").strip().lower() not in ("", "0", "false", "no", "off")


def shows_traceback(e: BaseException) -> bool:
    """Whether reporting `e` should include its traceback: a RioError is a problem the user can act on
    and its message says what to do (one line; the traceback only with `debug()`); any other exception is
    a bug, whose traceback is what to report."""
    return debug() or not isinstance(e, RioError)
