"""The bare transports under each middleware, as echo ping-pongs with the benchmark's payload.

Each `open_<name>(payload)` is a context manager yielding `roundtrip(payload) -> reply`: one request
and its echoed reply, nothing else (no node, no dispatcher, no serializer beyond turning the array
into bytes). The middleware benchmark times these with the same loop it times `client.echo()` with,
so `node API / raw` is the overhead RIO adds on top of the transport it is built on.

Servers of the process transports run in *spawned* children (never forked: zmq and zenoh own
threads) that exit on an explicit stop message, on EOF of their control pipe, or when the parent
dies (parent-death signal). Vendor packages (zmq, zenoh, portal) are imported only inside the
function that needs them.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import select
import signal
import socket
import tempfile
import threading
import time
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, NoReturn

import numpy as np

from rio.machine import host

RoundTrip = Callable[[np.ndarray], Any]

_READY_TIMEOUT_S = 30.0
_RECV_TIMEOUT_S = 10.0


@dataclass(frozen=True)
class RawTransport:
    name: str
    description: str
    open: Callable[[np.ndarray], contextlib.AbstractContextManager[RoundTrip]]


# -- helpers ---------------------------------------------------------------------------------------
def _child_init() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl+C stops the parent, which stops us
    host.exit_with_parent(os.getppid())


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_msg(conn: Any, proc: Any, what: str, timeout: float = _READY_TIMEOUT_S) -> Any:
    """Next message from a child's control pipe; raise if it dies or stays silent."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if conn.poll(0.05):
            try:
                msg = conn.recv()
            except EOFError:
                raise RuntimeError(f"{what}: server process exited (code {proc.exitcode})") from None
            if isinstance(msg, dict) and "error" in msg:
                raise RuntimeError(f"{what}: server failed: {msg['error']}")
            return msg
        if not proc.is_alive():
            raise RuntimeError(f"{what}: server process exited during start-up (code {proc.exitcode})")
    raise RuntimeError(f"{what}: server not ready after {timeout:.0f} s")


def _stop(proc: Any, timeout: float = 3.0) -> None:
    if proc.pid is None:  # never started
        return
    proc.join(timeout)
    if proc.is_alive():
        proc.terminate()
        proc.join(1.0)
    if proc.is_alive():
        proc.kill()
        proc.join(1.0)


def _report_error(conn: Any, e: BaseException) -> None:
    try:
        conn.send({"error": f"{type(e).__name__}: {e}"})
    except OSError:
        pass


def _end_child(e: BaseException) -> NoReturn:
    """End a server child whose error `_report_error` sent: the parent says it in one line, so the
    child's traceback (multiprocessing prints it) is left out, unless `rio --debug`."""
    from rio.errors import debug

    if debug():
        raise e
    raise SystemExit(1) from None


# -- thread: threading.Condition ping-pong between two threads -------------------------------------
@contextlib.contextmanager
def open_thread(payload: np.ndarray) -> Iterator[RoundTrip]:
    cond = threading.Condition()
    box: dict[str, Any] = {"state": 0, "slot": None, "stop": False}

    def serve() -> None:
        with cond:
            while True:
                while box["state"] != 1 and not box["stop"]:
                    cond.wait()
                if box["stop"]:
                    return
                box["slot"] = box["slot"]  # echo: the reply is the request object, as a direct call
                box["state"] = 2
                cond.notify()

    t = threading.Thread(target=serve, name="rio-bench-raw-thread", daemon=True)
    t.start()

    def roundtrip(p: np.ndarray) -> Any:
        with cond:
            box["slot"], box["state"] = p, 1
            cond.notify()
            while box["state"] != 2:
                cond.wait()
            box["state"] = 0
            return box["slot"]

    try:
        yield roundtrip
    finally:
        with cond:
            box["stop"] = True
            cond.notify_all()
        t.join(2.0)


# -- shm: shared-memory block + os.pipe wake-ups between two processes ----------------------------
def _shm_server(path: str, nbytes: int, req_r: Any, rep_w: Any) -> None:
    import mmap

    _child_init()
    rfd, wfd = req_r.fileno(), rep_w.fileno()
    with open(path, "r+b") as f:
        mm = mmap.mmap(f.fileno(), 2 * nbytes)
    req = np.ndarray((nbytes,), np.uint8, buffer=mm, offset=0)
    rep = np.ndarray((nbytes,), np.uint8, buffer=mm, offset=nbytes)
    local = np.empty(nbytes, np.uint8)
    os.write(wfd, b"r")
    while True:
        b = os.read(rfd, 1)
        if not b or b == b"q":
            break
        np.copyto(local, req)  # read the request out of shared memory ...
        np.copyto(rep, local)  # ... and write the echoed reply back into it
        os.write(wfd, b"x")
    del req, rep
    mm.close()


@contextlib.contextmanager
def open_shm(payload: np.ndarray) -> Iterator[RoundTrip]:
    nbytes = payload.nbytes
    d = "/dev/shm" if os.path.isdir("/dev/shm") else None
    fd, path = tempfile.mkstemp(prefix="rio-bench-", dir=d)
    ctx = mp.get_context("spawn")
    proc = None
    req_w = rep_r = None
    try:
        os.ftruncate(fd, 2 * nbytes)
        import mmap

        mm = mmap.mmap(fd, 2 * nbytes)
        req = np.ndarray((nbytes,), np.uint8, buffer=mm, offset=0)
        rep = np.ndarray((nbytes,), np.uint8, buffer=mm, offset=nbytes)
        req_r, req_w = ctx.Pipe(duplex=False)  # plain os.pipe() pairs underneath
        rep_r, rep_w = ctx.Pipe(duplex=False)
        proc = ctx.Process(target=_shm_server, args=(path, nbytes, req_r, rep_w), daemon=True,
                           name="rio-bench-raw-shm")
        proc.start()
        req_r.close()
        rep_w.close()
        wfd, rfd = req_w.fileno(), rep_r.fileno()
        ready, _, _ = select.select([rfd], [], [], _READY_TIMEOUT_S)
        if not ready or os.read(rfd, 1) != b"r":
            raise RuntimeError(f"shm raw: server not ready (exit code {proc.exitcode})")

        def roundtrip(p: np.ndarray) -> np.ndarray:
            np.copyto(req, p.reshape(-1).view(np.uint8))
            os.write(wfd, b"x")
            if not os.read(rfd, 1):
                raise RuntimeError("shm raw: server process exited")
            return rep.copy()

        try:
            yield roundtrip
        finally:
            with contextlib.suppress(OSError):
                os.write(wfd, b"q")
        # the mapping is unmapped with its last view (numpy views keep it exported until then)
    finally:
        for c in (req_w, rep_r):
            if c is not None:
                c.close()
        if proc is not None:
            _stop(proc)
        os.close(fd)
        with contextlib.suppress(OSError):
            os.unlink(path)


# -- zmq: DEALER/ROUTER over tcp://127.0.0.1 -------------------------------------------------------
def _zmq_server(conn: Any) -> None:
    _child_init()
    try:
        import zmq

        zctx = zmq.Context()
        sock = zctx.socket(zmq.ROUTER)
        sock.setsockopt(zmq.LINGER, 0)
        port = sock.bind_to_random_port("tcp://127.0.0.1")
    except BaseException as e:
        _report_error(conn, e)
        _end_child(e)
    conn.send({"port": port})
    while True:
        ident, msg = sock.recv_multipart()
        if not msg:
            break
        sock.send_multipart((ident, msg))
    sock.close(0)
    zctx.term()


def _spawn_echo_server(target: Any, *args: Any, name: str) -> tuple[Any, Any]:
    """Start a raw echo server in a spawned child; returns (process, our end of its control pipe)."""
    ctx = mp.get_context("spawn")
    conn, child_conn = ctx.Pipe()
    proc = ctx.Process(target=target, args=(child_conn, *args), daemon=True, name=name)
    proc.start()
    child_conn.close()
    return proc, conn


@contextlib.contextmanager
def open_zmq(payload: np.ndarray) -> Iterator[RoundTrip]:
    import zmq

    proc, conn = _spawn_echo_server(_zmq_server, name="rio-bench-raw-zmq")
    zctx = sock = None
    try:
        port = _wait_msg(conn, proc, "zmq raw")["port"]
        zctx = zmq.Context()
        sock = zctx.socket(zmq.DEALER)
        sock.setsockopt(zmq.LINGER, 0)
        sock.setsockopt(zmq.RCVTIMEO, int(_RECV_TIMEOUT_S * 1000))
        sock.connect(f"tcp://127.0.0.1:{port}")

        def roundtrip(p: np.ndarray) -> np.ndarray:
            sock.send(p.tobytes())
            return np.frombuffer(sock.recv(), p.dtype)

        try:
            yield roundtrip
        finally:
            with contextlib.suppress(zmq.ZMQError):
                sock.send(b"", zmq.NOBLOCK)
    finally:
        if sock is not None:
            sock.close(0)
        if zctx is not None:
            zctx.term()
        conn.close()
        _stop(proc)


# -- zenoh: pub/sub ping-pong between two peer sessions --------------------------------------------
def zenoh_config(listen: list[str] | None = None, connect: list[str] | None = None) -> Any:
    """Peer session on explicit tcp/127.0.0.1 endpoints; multicast and gossip scouting off (they
    would find every other zenoh program on the machine and add their traffic to ours)."""
    import json

    import zenoh

    conf = {
        "mode": "peer",
        "listen": {"endpoints": listen or []},
        "connect": {"endpoints": connect or []},
        "scouting": {"multicast": {"enabled": False}, "gossip": {"enabled": False}},
    }
    return zenoh.Config.from_json5(json.dumps(conf))


def _wait_matching(pub: Any, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not pub.matching_status:
        if time.monotonic() > deadline:
            raise RuntimeError(f"{what}: no matching subscriber after {timeout:.0f} s")
        time.sleep(0.005)


def _zenoh_server(conn: Any, port: int, ping: str, pong: str) -> None:
    _child_init()
    try:
        import zenoh

        session = zenoh.open(zenoh_config(connect=[f"tcp/127.0.0.1:{port}"]))
        pub = session.declare_publisher(pong, express=True)

        def on_ping(sample: Any) -> None:
            pub.put(sample.payload)

        sub = session.declare_subscriber(ping, on_ping)
        _wait_matching(pub, _READY_TIMEOUT_S, "zenoh raw (server)")
    except BaseException as e:
        _report_error(conn, e)
        _end_child(e)
    conn.send({"ready": True})
    try:
        conn.recv()  # stop message, or EOF when the parent goes away
    except (EOFError, OSError):
        pass
    sub.undeclare()
    pub.undeclare()
    session.close()


@contextlib.contextmanager
def open_zenoh(payload: np.ndarray) -> Iterator[RoundTrip]:
    import queue

    import zenoh

    port = free_port()
    base = f"rio-bench/{uuid.uuid4().hex[:12]}"
    ping, pong = f"{base}/ping", f"{base}/pong"
    session = zenoh.open(zenoh_config(listen=[f"tcp/127.0.0.1:{port}"]))
    ctx = mp.get_context("spawn")
    conn, child_conn = ctx.Pipe()
    proc = ctx.Process(target=_zenoh_server, args=(child_conn, port, ping, pong), daemon=True,
                       name="rio-bench-raw-zenoh")
    replies: queue.SimpleQueue = queue.SimpleQueue()
    sub = pub = None
    try:
        sub = session.declare_subscriber(pong, lambda s: replies.put(s.payload.to_bytes()))
        pub = session.declare_publisher(ping, express=True)
        proc.start()
        child_conn.close()
        _wait_msg(conn, proc, "zenoh raw")
        _wait_matching(pub, _READY_TIMEOUT_S, "zenoh raw")
        # Matching declarations do not yet mean the data route works both ways: a first put can
        # still be lost. Ping until a pong comes back, then drop any late duplicates.
        deadline = time.monotonic() + _READY_TIMEOUT_S
        tries = 0
        while True:
            tries += 1
            pub.put(payload.tobytes())
            try:
                replies.get(timeout=0.2)
                break
            except queue.Empty:
                if time.monotonic() > deadline or not proc.is_alive():
                    raise RuntimeError(f"zenoh raw: no echo after {tries} pings") from None
        time.sleep(0.2)
        while not replies.empty():
            replies.get_nowait()

        def roundtrip(p: np.ndarray) -> np.ndarray:
            pub.put(p.tobytes())
            try:
                return np.frombuffer(replies.get(timeout=_RECV_TIMEOUT_S), p.dtype)
            except queue.Empty:
                raise RuntimeError(f"zenoh raw: no reply within {_RECV_TIMEOUT_S:.0f} s") from None

        yield roundtrip
    finally:
        with contextlib.suppress(OSError):
            conn.send("stop")
        conn.close()
        _stop(proc)
        for x in (sub, pub):
            if x is not None:
                with contextlib.suppress(Exception):
                    x.undeclare()
        session.close()


# -- portal: portal.Server echo function, portal.Client ------------------------------------------
@contextlib.contextmanager
def keep_start_method() -> Iterator[None]:
    """`import portal` calls multiprocessing.set_start_method('spawn') for the whole program; put
    the caller's setting back afterwards (None: still unset, the platform default applies)."""
    saved = mp.get_start_method(allow_none=True)
    try:
        yield
    finally:
        if mp.get_start_method(allow_none=True) != saved:
            mp.set_start_method(saved, force=True)


def _portal_server(conn: Any) -> None:
    _child_init()
    try:
        import portal

        port = portal.free_port()
        server = portal.Server(port, name="RioBenchRaw", host="127.0.0.1", logging=False)
        server.bind("echo", lambda x: x)
        server.start(block=False)
    except BaseException as e:
        _report_error(conn, e)
        _end_child(e)
    conn.send({"port": port})
    try:
        conn.recv()
    except (EOFError, OSError):
        pass
    server.close(timeout=2.0)


@contextlib.contextmanager
def open_portal(payload: np.ndarray) -> Iterator[RoundTrip]:
    with keep_start_method():  # first: without portal installed, no server process is started to fail
        import portal
    proc, conn = _spawn_echo_server(_portal_server, name="rio-bench-raw-portal")
    client = None
    try:
        port = _wait_msg(conn, proc, "portal raw")["port"]
        client = portal.Client(f"127.0.0.1:{port}", name="RioBenchRawClient", logging=False)

        def roundtrip(p: np.ndarray) -> Any:
            return client.call("echo", p).result(timeout=_RECV_TIMEOUT_S)

        yield roundtrip
    finally:
        if client is not None:
            with contextlib.suppress(Exception):
                client.close(timeout=2.0)
        with contextlib.suppress(OSError):
            conn.send("stop")
        conn.close()
        _stop(proc)


RAW: dict[str, RawTransport] = {
    "thread": RawTransport("thread", "threading.Condition ping-pong between two threads", open_thread),
    "shm": RawTransport("shm", "2 processes: payload copied through a shared-memory block (/dev/shm mmap), "
                               "1-byte os.pipe() wake-ups each way", open_shm),
    "zmq": RawTransport("zmq", "2 processes: pyzmq DEALER -> ROUTER echo over tcp://127.0.0.1", open_zmq),
    "zenoh": RawTransport("zenoh", "2 processes: zenoh peer sessions over tcp/127.0.0.1 (scouting off), "
                                   "put on ping / callback put on pong", open_zenoh),
    "portal": RawTransport("portal", "2 processes: portal.Server echo function, portal.Client call over "
                                     "127.0.0.1", open_portal),
}
