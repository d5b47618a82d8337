"""The HTTPS server of the WebXR page and its WebSocket (aiohttp, in a thread with its own event loop).

`GET /` is the page, `GET /teleop.js` its script (package data, no build step), `GET /ws` the
WebSocket. One operator at a time: a second page is told so and closed, and the operator's page is
closed (4002) once it has sent nothing for `silence_s` (the page pings every 0.5 s), so a client that
connects and goes silent frees the slot; the arm's stale watchdog (`stale_s`) is separate and holds the
arm long before. A page whose `Origin` is not
this server is refused (another site open in the headset's browser cannot drive the robot). Frames
over `protocol.MAX_HANDS_BYTES` close the connection (aiohttp's `max_msg_size`; the check refuses
every message but `hands` past `protocol.MAX_BYTES`), compression is not offered (no decompression
bombs), every text frame is validated (`protocol.parse`) before the handler sees it, and a page
flooding the socket past `MAX_RATE_HZ` has the excess dropped.
"""

from __future__ import annotations

import asyncio
import json
import ssl
import threading
from collections.abc import Callable
from importlib import resources
from typing import Any, Protocol

from rio import clock

from . import protocol

MAX_RATE_HZ = 400
SILENCE_S = 5.0  # the default of the node's `silence_s`
SILENT = 4002  # the close code of a page that went silent
STATUS_HZ = 10
_TYPES = {"index.html": "text/html", "teleop.js": "text/javascript"}
_CSP = ("default-src 'none'; script-src 'self'; style-src 'self' 'unsafe-inline'; connect-src 'self'; "
        "img-src 'self' data:; base-uri 'none'; form-action 'none'; frame-ancestors 'none'")


class Handler(Protocol):
    def page_config(self) -> dict[str, Any]: ...
    def connected(self) -> None: ...
    def disconnected(self) -> None: ...
    def message(self, msg: dict[str, Any]) -> None: ...
    def status(self) -> dict[str, Any]: ...


def _asset(name: str) -> bytes:
    return resources.files(__package__).joinpath("static", name).read_bytes()


class WebXRServer:
    def __init__(self, handler: Handler, host: str, port: int, ssl_context: ssl.SSLContext | None,
                 extra_routes: Callable[[Any], None] | None = None, silence_s: float = SILENCE_S):
        self.handler, self.host, self.port, self.ssl = handler, host, int(port), ssl_context
        self.silence_s = float(silence_s)
        self.silenced = 0  # operators disconnected for silence
        self.extra_routes = extra_routes
        self.rejected = 0
        self.dropped = 0
        self._active: Any = None  # the operator's WebSocketResponse
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._runner: Any = None
        self._stopped: asyncio.Event | None = None

    # -- lifecycle (called from the node's thread) -------------------------------------------------
    def start(self, timeout: float = 10.0) -> None:
        ready = threading.Event()
        error: list[BaseException] = []

        def run() -> None:
            loop = asyncio.new_event_loop()
            self._loop = loop
            asyncio.set_event_loop(loop)
            try:
                loop.run_until_complete(self._serve(ready))
            except BaseException as e:  # noqa: BLE001 - handed to start()
                error.append(e)
                ready.set()
            finally:
                loop.close()

        self._thread = threading.Thread(target=run, name=f"webxr-{self.port}", daemon=True)
        self._thread.start()
        if not ready.wait(timeout):
            raise RuntimeError(f"teleop.webxr: the page's server did not start within {timeout:g} s")
        if error:
            e = error[0]
            if isinstance(e, OSError):
                raise RuntimeError(f"teleop.webxr: cannot serve on {self.host}:{self.port}: {e.strerror or e} "
                                   "(another program on that port? set `port` in the teleop component)") from None
            raise e

    def stop(self, timeout: float = 5.0) -> None:
        loop, stopped = self._loop, self._stopped
        if loop is not None and stopped is not None and not loop.is_closed():
            try:
                loop.call_soon_threadsafe(stopped.set)
            except RuntimeError:
                pass  # the loop already ended
        if self._thread is not None:
            self._thread.join(timeout)

    # -- inside the event loop ---------------------------------------------------------------------
    async def _serve(self, ready: threading.Event) -> None:
        from aiohttp import web

        self._stopped = asyncio.Event()
        app = web.Application(client_max_size=4096)
        app.router.add_get("/", self._page)
        app.router.add_get("/teleop.js", self._script)
        app.router.add_get("/ws", self._ws)
        if self.extra_routes is not None:
            self.extra_routes(app)
        self._runner = web.AppRunner(app, access_log=None, handle_signals=False)
        await self._runner.setup()
        try:
            site = web.TCPSite(self._runner, self.host, self.port, ssl_context=self.ssl, reuse_address=True)
            await site.start()
            server = getattr(site, "_server", None)
            if self.port == 0 and server is not None and server.sockets:
                self.port = int(server.sockets[0].getsockname()[1])
            ready.set()
            await self._stopped.wait()
        finally:
            if self._active is not None:
                await self._active.close(code=1001, message=b"the robot's teleop ended")
            await self._runner.cleanup()

    def _headers(self, kind: str) -> dict[str, str]:
        return {"Content-Type": f"{kind}; charset=utf-8", "Cache-Control": "no-store", "Content-Security-Policy": _CSP,
                "X-Content-Type-Options": "nosniff", "Referrer-Policy": "no-referrer"}

    async def _page(self, request: Any) -> Any:
        from aiohttp import web

        return web.Response(body=_asset("index.html"), headers=self._headers("text/html"))

    async def _script(self, request: Any) -> Any:
        from aiohttp import web

        return web.Response(body=_asset("teleop.js"), headers=self._headers("text/javascript"))

    def _same_origin(self, request: Any) -> bool:
        origin = request.headers.get("Origin")
        if origin is None:
            return True  # not a browser (a browser always sends it on a WebSocket)
        return origin == f"{request.scheme}://{request.host}"

    async def _ws(self, request: Any) -> Any:
        from aiohttp import WSMsgType, web

        if not self._same_origin(request):
            return web.Response(status=403, text="teleop.webxr: this page is served from another origin")
        ws = web.WebSocketResponse(max_msg_size=protocol.MAX_HANDS_BYTES, compress=False, heartbeat=None,
                                   autoping=True)
        await ws.prepare(request)
        if self._active is not None and not self._active.closed:
            await ws.send_str(json.dumps({"type": "error", "message": "another operator is connected; "
                                                                      "close that page first"}))
            await ws.close(code=4001, message=b"busy")
            return ws
        self._active = ws
        self.handler.connected()
        pusher: Any = None
        errors, window_t, window_n = 0, clock.now(), 0
        try:
            await ws.send_str(json.dumps({"type": "config", **self.handler.page_config()}))
            pusher = asyncio.ensure_future(self._push_status(ws))
            heard = clock.now()
            while True:
                try:  # any text frame counts as heard (WebSocket control frames do not)
                    msg = await ws.receive(timeout=max(0.0, heard + self.silence_s - clock.now()))
                except asyncio.TimeoutError:
                    self.silenced += 1
                    await ws.close(code=SILENT, message=f"silent for {self.silence_s:g} s".encode())
                    break
                if msg.type == WSMsgType.TEXT:
                    now = heard = clock.now()
                    if now - window_t >= 1.0:
                        window_t, window_n = now, 0
                    window_n += 1
                    if window_n > MAX_RATE_HZ:
                        self.dropped += 1
                        continue
                    try:
                        parsed = protocol.parse(msg.data)
                    except protocol.ProtocolError as e:
                        self.rejected += 1
                        errors += 1
                        await ws.send_str(json.dumps({"type": "error", "message": str(e)[:200]}))
                        if errors >= protocol.MAX_ERRORS:
                            await ws.close(code=1008, message=b"too many invalid messages")
                            break
                        continue
                    if parsed["type"] == "ping":
                        await ws.send_str(json.dumps({"type": "pong", "id": parsed["id"], "t": parsed["t"],
                                                      "server_t": clock.now()}))
                    else:
                        self.handler.message(parsed)
                elif msg.type == WSMsgType.BINARY:
                    self.rejected += 1
                    await ws.close(code=1003, message=b"binary frames are not accepted")
                    break
                else:  # ERROR (e.g. a frame over max_msg_size) or CLOSE
                    if msg.type == WSMsgType.ERROR:
                        self.rejected += 1
                    break
        finally:
            if pusher is not None:
                pusher.cancel()
            if self._active is ws:
                self._active = None
                self.handler.disconnected()
            if not ws.closed:
                await ws.close()
        return ws

    async def _push_status(self, ws: Any) -> None:
        try:
            while not ws.closed:
                status = {"type": "status", **self.handler.status(), "rejected": self.rejected, "dropped": self.dropped}
                await ws.send_str(json.dumps(status))
                await asyncio.sleep(1.0 / STATUS_HZ)
        except (ConnectionError, RuntimeError, asyncio.CancelledError):
            pass
