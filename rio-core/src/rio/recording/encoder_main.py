"""The encoder process: turns camera frames into video files while the control loop runs on.

It is started once per `Recorder` (`python -m rio.recording.encoder_main FD NICE`), runs at a lower
CPU priority than the control loop, and takes
small commands over a pipe (frames themselves arrive through `FrameRing` shared memory):

    ("ring", key, shape, dtype, slots) + an fd    map a stream's frame ring
    ("open", key, path, kind, h, w, rate, opts)   start writing a stream to a file
    ("frame", key, slot, depth_scale)             encode that slot, then release it (depth_scale: the
                                                  slot's depth is in those units, None: in meters)
    ("close", token, keys)                        finish streams, fsync, reply ("closed", token, result)
    ("abort", token, keys)                        stop streams without caring, reply ("aborted", token)
    ("exit",)

Its own GIL and process keep encoding from ever stalling the control loop. If the recording
process dies, the pipe reaches EOF and this process closes its open files cleanly (a complete last
fragment) before exiting: the interrupted episode is then recoverable with `rio datasets repair`.
"""

from __future__ import annotations

import os
import signal
import traceback
from typing import Any


def encoder_main(conn: Any, nice: int = 10) -> None:
    from multiprocessing.reduction import recv_handle

    from rio.recording.durable import fsync_file
    from rio.recording.frame_ring import FrameRing
    from rio.recording.video import StreamWriter, VideoOptions

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl+C belongs to the recorder, which closes episodes
    try:
        os.nice(nice)
    except OSError:
        pass
    rings: dict[str, FrameRing] = {}
    writers: dict[str, StreamWriter] = {}
    failed: dict[str, str] = {}

    def report(key: str, what: str) -> None:
        failed[key] = what
        try:
            conn.send(("error", key, what))
        except OSError:
            pass

    def finish(keys: list[str], sync: bool) -> dict[str, dict]:
        out: dict[str, dict] = {}
        for key in keys:
            w = writers.pop(key, None)
            if w is None:
                out[key] = {"frames": 0, "error": failed.pop(key, "never opened")}
                continue
            try:
                n = w.close()
                if sync:
                    fsync_file(w.path)
                out[key] = {"frames": n}
            except Exception as e:  # noqa: BLE001 - reported to the recorder
                out[key] = {"frames": w.frames, "error": f"{type(e).__name__}: {e}"}
            if key in failed:
                out[key]["error"] = failed.pop(key)
        return out

    while True:
        try:
            msg = conn.recv()
        except (EOFError, ConnectionError):  # the recorder is gone: end every stream on a whole fragment
            finish(list(writers), sync=True)
            return
        except OSError as e:  # not the recorder's exit (EAGAIN: a non-blocking socket): say so, not exit 0
            finish(list(writers), sync=True)
            raise SystemExit(f"rio encoder: cannot read the recorder's commands: {e}") from None
        op = msg[0]
        if op == "frame":
            _, key, slot, depth_scale = msg
            ring = rings[key]
            w = writers.get(key)
            try:
                if w is not None:
                    w.write(ring.view(slot), depth_scale)
            except Exception as e:  # noqa: BLE001
                report(key, f"encoding failed: {type(e).__name__}: {e}")
                writers.pop(key, None)
            finally:
                try:  # through the kernel, not shared memory: see frame_ring's note on memory order
                    conn.send(("released", key))
                except OSError:
                    pass
        elif op == "ring":
            _, key, shape, dtype, slots = msg
            fd = recv_handle(conn)
            if key in rings:
                rings[key].close()
            rings[key] = FrameRing(shape, dtype, slots, fd=fd)
        elif op == "open":
            _, key, path, kind, h, w, rate, opts = msg
            try:
                writers[key] = StreamWriter(path, kind, h, w, rate, VideoOptions(**opts))
                failed.pop(key, None)
            except Exception as e:  # noqa: BLE001
                report(key, f"cannot open the encoder: {type(e).__name__}: {e}\n{traceback.format_exc(limit=2)}")
        elif op == "close":
            _, token, keys = msg
            conn.send(("closed", token, finish(keys, sync=True)))
        elif op == "abort":
            _, token, keys = msg
            finish(keys, sync=False)
            conn.send(("aborted", token))
        elif op == "exit":
            finish(list(writers), sync=True)
            for r in rings.values():
                r.close()
            return


if __name__ == "__main__":
    import sys
    from multiprocessing.connection import Connection

    fd = int(sys.argv[1])
    # Reads wait for the next command, however the socket was made (a process-wide socket timeout in the
    # recorder makes new sockets non-blocking: see EncoderProcess).
    os.set_blocking(fd, True)
    encoder_main(Connection(fd), int(sys.argv[2]) if len(sys.argv) > 2 else 10)
